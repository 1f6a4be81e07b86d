# The paper's Table I and Fig. 3 on SYNTHETIC tiers: gen-formulas -> compile-dfa -> gen-traces
# -> train-edge -> train-meta (one q per row and seed) -> eval model-checking -> one table.
# Re-runs only what changed; `make -j` runs independent branches in parallel.
#   make -f pipelines/model_checking.mk [TLEAF=tleaf] [SMALL=1] [JOBS=2] [ROWS="dfa paper syntax"]
# SMALL=1: the whole chain on a tiny synthetic set in about a minute (tests).
#
# Rows of the table (one q_m per tier and seed each; docs/results/model_checking.md):
#   dfa     train-meta's default, preset best: the DFA embedder with temporal monitors and their
#           naive-Bayes evidence (docs/embedder.md)
#   paper   train-meta --preset paper: the 2021 paper's q (GCN, walk readout, triplet loss)
#   syntax  the paper's syntax-tree baseline, with the best preset's trace encoder and losses
TLEAF ?= tleaf
JOBS ?= 2
SMALL ?= 0
# formulas are drawn with this seed (the models' seeds are SEEDS)
DATA_SEED ?= 0
ROWS ?= dfa paper syntax
# Table I's MLP reads [z_φ ; z_w ; |z_φ − z_w| ; z_φ ⊙ z_w] (rich) for every row, or the
# concatenation alone (concat). The paper names the MLP (512, 128), not its input; whether w
# satisfies φ is a relation between the two vectors, which an MLP that sees them side by side
# only cannot form from a dot product (docs/results/model_checking.md).
PAIR_FEATURES ?= rich
# where q_e and q_m train and the evaluations' MLPs fit: cpu, or cuda
DEVICE ?= cpu
# the evaluations' MLP products: auto (bfloat16 under autocast where the hardware computes it
# natively: 3-4x faster products on CPUs with AMX / AVX-512 BF16; float32 elsewhere), float32,
# or bfloat16 (docs/results/model_checking.md: what it changes)
PRECISION ?= auto
# more train-meta options for the dfa row, e.g. META_FLAGS="--probes 16 --epochs 12"
META_FLAGS ?=
# One torch thread per process: `make -j` already runs a process per core, and torch's own
# threads on top of that oversubscribe the cores (8.6 s instead of 0.07 s per q_m batch on a
# loaded 2-core machine). Override with OMP_NUM_THREADS=2 for a single-job run.
export OMP_NUM_THREADS ?= 1

ifeq ($(SMALL),1)
OUT ?= out/model-checking-small
TIERS ?= low
SEEDS ?= 0
N := 40
K := 8
EDGE := --epochs 2 --hidden 32 --out-dim 16
SIZE := --epochs 3 --hidden 32 --layers 2 --out-dim 16
else
OUT ?= out/model-checking
TIERS ?= low moderate high
SEEDS ?= 0 1 2
# formulas per tier and pairs per formula: more formulas help, at proportional cost
N ?= 1000
K := 20
# q_e: one per tier (seed 0), shared by the tier's q_m of every row and seed: it reads guards
# only, its held-out accuracy was 0.96-0.98 at every seed, and its best epoch the 3rd to 5th
EDGE := --epochs 3
SIZE :=
endif
# each row's train-meta options (the syntax baseline trains 3 epochs: its val score stops
# rising by then)
META_dfa = $(SIZE) $(META_FLAGS)
META_paper = --preset paper $(SIZE)
META_syntax = --embedder syntax $(if $(SIZE),$(SIZE),--epochs 3)

REPORTS := $(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,$(ROWS),\
	$(OUT)/$(t)/seed$(s)/eval-$(e)/report.json)))
# make -j starts prerequisites in the order they are listed: the same reports, the last tier
# (the slowest) and the dfa runs first, so that its long chain (q_e, then q_m, then evaluation)
# starts at once and short jobs fill the end
reverse = $(if $(1),$(call reverse,$(wordlist 2,$(words $(1)),$(1))) $(firstword $(1)))
SCHEDULE := $(foreach t,$(call reverse,$(TIERS)),$(foreach s,$(SEEDS),$(foreach e,$(ROWS),\
	$(OUT)/$(t)/seed$(s)/eval-$(e)/report.json)))

# The paper's Fig. 3 for the first tier and seed: one test formula, syntax and DFA q side by side.
T1 := $(firstword $(TIERS))
S1 := $(firstword $(SEEDS))
FIGURE := $(OUT)/tsne-$(T1)-seed$(S1).png
FIGURE_ROWS := $(filter syntax dfa,$(ROWS))

.PHONY: all clean
all: $(OUT)/results.md $(if $(filter 2,$(words $(FIGURE_ROWS))),$(FIGURE))

$(OUT)/results.md: $(SCHEDULE)
	$(TLEAF) eval table $(REPORTS) -o $@

$(FIGURE): $(OUT)/$(T1)/seed$(S1)/meta-syntax/metrics.json $(OUT)/$(T1)/seed$(S1)/meta-dfa/metrics.json
	$(TLEAF) eval tsne $(OUT)/$(T1)/dfas.parquet $(OUT)/$(T1)/traces.parquet \
	    --embedder $(OUT)/$(T1)/seed$(S1)/meta-syntax --embedder $(OUT)/$(T1)/seed$(S1)/meta-dfa \
	    --seed $(S1) -o $@ -q

# data: one synthetic set per tier (DATA_SEED)
$(OUT)/%/formulas.ltl:
	@mkdir -p $(@D)
	$(TLEAF) gen-formulas --tier $* -n $(N) --pairs $(K) --seed $(DATA_SEED) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q -o $@
$(OUT)/%/dfas.parquet: $(OUT)/%/formulas.ltl
	$(TLEAF) compile-dfa $< --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q -o $@
$(OUT)/%/traces.parquet: $(OUT)/%/dfas.parquet
	$(TLEAF) gen-traces $< --per-formula $(K) --split 0.8,0.1,0.1 --seed $(DATA_SEED) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q -o $@

# models and evaluations: one q_e per tier, then per row and seed q_m and its evaluation
$(OUT)/%/edge/metrics.json: $(OUT)/%/dfas.parquet
	$(TLEAF) train-edge $< -o $(@D) $(EDGE) --device $(DEVICE) --seed 0 -q
define RUN
$(OUT)/$(1)/seed$(2)/meta-$(3)/metrics.json: $(OUT)/$(1)/traces.parquet $(OUT)/$(1)/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/$(1)/dfas.parquet $$< --edge $(OUT)/$(1)/edge \
	    -o $$(@D) $(META_$(3)) --device $(DEVICE) --seed $(2) -q
$(OUT)/$(1)/seed$(2)/eval-$(3)/report.json: $(OUT)/$(1)/seed$(2)/meta-$(3)/metrics.json
	$(TLEAF) eval model-checking $(OUT)/$(1)/dfas.parquet $(OUT)/$(1)/traces.parquet \
	    --embedder $(OUT)/$(1)/seed$(2)/meta-$(3) -o $$(@D) --label $(1) --seed $(2) \
	    --pair-features $(PAIR_FEATURES) --device $(DEVICE) --precision $(PRECISION) -q
endef
$(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,$(ROWS),$(eval $(call RUN,$(t),$(s),$(e))))))

# the pattern rules' files are kept (.PRECIOUS), not every target made secondary: with
# .SECONDARY a finished report would hide seeds or rows added later
.PRECIOUS: $(OUT)/%/formulas.ltl $(OUT)/%/dfas.parquet $(OUT)/%/traces.parquet \
    $(OUT)/%/edge/metrics.json
clean:
	rm -rf $(OUT)
