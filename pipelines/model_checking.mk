# The paper's Table I (issue 5): tiers x seeds x {syntax, dfa} embedders, from gen-formulas to
# one results table. Re-runs only what changed; `make -j` runs independent branches in parallel.
#   make -f pipelines/model_checking.mk [TLEAF=tleaf] [SMALL=1] [JOBS=2]
# SMALL=1: the whole chain on a tiny synthetic set in about a minute (tests, README demo).
TLEAF ?= tleaf
JOBS ?= 2
SMALL ?= 0
# formulas are drawn with this seed (the models' seeds are SEEDS)
DATA_SEED ?= 0
# Table I's MLP reads [z_φ ; z_w ; |z_φ − z_w| ; z_φ ⊙ z_w] (rich) for both rows, or the
# concatenation alone (concat, the pipeline's until the ninth session). The paper names the MLP
# (512, 128), not its input; whether w satisfies φ is a relation between the two vectors, and a
# score that is a dot product (the evidence block below) is out of reach of an MLP that sees them
# side by side only (docs/results/model_checking.md, ninth session).
PAIR_FEATURES ?= rich
# where q_e and q_m train: cpu, or cuda (evaluations stay on the CPU). On one H200 with 16 cores
# the per-epoch gain is 1.4x (High q_e) to 2.6x (High q_m); the work is mostly CPU-side batch
# building (docs/results/model_checking.md, "On a GPU").
DEVICE ?= cpu
# One torch thread per process: `make -j` already runs a process per core, and torch's own
# threads on top of that oversubscribe the cores (measured: 8.6 s instead of 0.07 s per q_m batch
# on a loaded 2-core machine). Override with OMP_NUM_THREADS=2 for a single-job run.
export OMP_NUM_THREADS ?= 1

# SPHERE=1 (issue 13, tenth session): q_m's learned part scaled to unit length (--sphere), so its
# squared distance (at most 4) no longer blurs the evidence block's (up to 4γ²): distance rule
# +0.2 / +0.4 / +4.1 points, MLP +0.2 / +0.1 / +0.6 on data seed 0 (data seed 1: +0.8 / +0.2 /
# +2.6, MLP -0.3 / +0.1 / +0.3; docs/results/model_checking.md, tenth session). DFA rows with
# the evidence block only; SPHERE=0: the ninth session's q
SPHERE ?= 1
sphere_flag = $(if $(filter 1,$(SPHERE)),$(if $(filter 0,$(EVIDENCE)),,--sphere))

ifeq ($(SMALL),1)
OUT ?= out/model-checking-small
TIERS ?= low
SEEDS ?= 0
N := 40
K := 8
EDGE := --epochs 2 --hidden 32 --out-dim 16
META := --epochs 3 --hidden 32 --layers 2 --out-dim 16 --directed --readout runs --bins 5
META_dfa := $(META) --monitors 3 --evidence $(sphere_flag)
META_syntax := $(META)
else
OUT ?= out/model-checking
TIERS ?= low moderate high
SEEDS ?= 0 1 2
# formulas per tier, q_m's epochs (DFA / syntax), pairs per formula: the 30-minute setting on
# 2 cores; more formulas help (results: Low at 1000, 2000, 4000 formulas), at proportional cost
N ?= 1000
EPOCHS ?= 6
SYNTAX_EPOCHS ?= 3
K := 20
# q_e: one per tier (seed 0), shared by the tier's three seeds of q_m: it reads guards only, its
# held-out accuracy was 0.96-0.98 at every seed, and training it per seed was the largest single
# cost of the pipeline (High: 40k distinct guards). 3 epochs: its best epoch was the 3rd to 5th.
EDGE := --epochs 3
# q_m: messages along and against the arcs (+10 points over an undirected GCN), read out where
# accepted and rejected runs go, in 5 parts of the run (docs/results/model_checking.md, "what
# was tried"); cosine learning rate over the epochs; the best val epoch is kept; one radius for
# all formulas learned beside the triplet loss (--radius-weight 1: the distance rule d < r that
# the tleaf loss reads, 61 -> 72 on Low, the MLP unchanged). The syntax baseline's trace encoder
# and losses are the same. Epoch counts fit the 30-minute budget on 2 cores. No early stop
# inside the schedule (--patience = the epochs): the learning rate only falls in the last
# epochs, the best val epoch was the last in 25 of the 26 DFA runs that ran them all, and
# --patience 3 once stopped a High run at epoch 4 on a lucky first epoch (67.7 instead of ~71).
META := --directed --readout runs --bins 5 --schedule cosine --patience $(EPOCHS) --radius-weight 1
# The larger setting (issue 13): PROBES=16 EPOCHS=12 adds 16 probe automata to q_m (--probes,
# docs/embedder.md) and trains it 12 epochs: Table I +0.6 / +2.5 / +3.4 points, at about 2.5x the
# pipeline's time (docs/results/model_checking.md, "The larger setting"). The syntax rows are the
# default setting's.
PROBES ?= 0
# Temporal monitors (issue 13, 2026-11-26): fixed small automata for F p, G p, p U q,
# G(p -> X q), ... over each formula's first K atoms; q_m reads the share of a DFA's accepted and
# rejected words each one accepts beside its GNN readout (--monitors, docs/embedder.md): Low
# 76.6 -> 83.6 at the same epochs (docs/results/model_checking.md). K per tier: the tier's atoms
# (Low and Moderate formulas have 3, High 6; until the ninth session every tier read 6 slots,
# the slots past a formula's atoms reading 0: the same information, 4.5x the features).
# MONITORS=K sets every tier's, MONITORS=0: the q of 2026-11-25. MONITOR_RANGES=3: the shares
# per third of the word lengths (a trace in its own), chosen over 1 on val triplet accuracy on
# both formula draws (Low +0.002, Moderate +0.003, High +0.03).
MONITORS ?=
monitors = $(if $(MONITORS),$(MONITORS),$(if $(filter high,$(1)),6,3))
MONITOR_RANGES ?= 3
# Evidence (issue 13, ninth session): the monitors' naive-Bayes score as a unit-sphere block of
# q's vectors (--evidence, docs/embedder.md), γ² = EVIDENCE_SCALE at the start; EVIDENCE=0: the
# q of the eighth session
EVIDENCE ?= 1
EVIDENCE_SCALE ?= 256
mon_flags = $(if $(filter-out 0,$(1)),--monitors $(1) \
    $(if $(filter-out 1,$(MONITOR_RANGES)),--monitor-ranges $(MONITOR_RANGES)) \
    $(if $(filter 1,$(EVIDENCE)),--evidence --evidence-scale $(EVIDENCE_SCALE)))
META_dfa = $(META) --epochs $(EPOCHS) $(call mon_flags,$(call monitors,$(1))) \
    $(if $(filter-out 0,$(PROBES)),--probes $(PROBES)) $(sphere_flag)
META_syntax := $(META) --epochs $(SYNTAX_EPOCHS)
endif

REPORTS := $(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,syntax dfa,\
	$(OUT)/$(t)/seed$(s)/eval-$(e)/report.json)))
# make -j starts prerequisites in the order they are listed: the same reports, the last tier
# (the slowest) and the DFA runs first, so that its long chain (q_e, then q_m, then evaluation)
# starts at once and short jobs fill the end (before: one core idled the last ~140 s, 2026-11-26)
reverse = $(if $(1),$(call reverse,$(wordlist 2,$(words $(1)),$(1))) $(firstword $(1)))
SCHEDULE := $(foreach t,$(call reverse,$(TIERS)),$(foreach s,$(SEEDS),$(foreach e,dfa syntax,\
	$(OUT)/$(t)/seed$(s)/eval-$(e)/report.json)))

# The paper's Fig. 3 for the first tier and seed: one test formula, both embedders side by side.
T1 := $(firstword $(TIERS))
S1 := $(firstword $(SEEDS))
FIGURE := $(OUT)/tsne-$(T1)-seed$(S1).png

.PHONY: all clean
all: $(OUT)/results.md $(FIGURE)

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

# models and evaluations: one q_e per tier, then per seed q_m (or the baseline) and its evaluation
$(OUT)/%/edge/metrics.json: $(OUT)/%/dfas.parquet
	$(TLEAF) train-edge $< -o $(@D) $(EDGE) --device $(DEVICE) --seed 0 -q
define RUN
$(OUT)/$(1)/seed$(2)/meta-$(3)/metrics.json: $(OUT)/$(1)/traces.parquet $(OUT)/$(1)/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/$(1)/dfas.parquet $$< --edge $(OUT)/$(1)/edge \
	    --embedder $(3) -o $$(@D) $(call META_$(3),$(1)) --device $(DEVICE) --seed $(2) -q
$(OUT)/$(1)/seed$(2)/eval-$(3)/report.json: $(OUT)/$(1)/seed$(2)/meta-$(3)/metrics.json
	$(TLEAF) eval model-checking $(OUT)/$(1)/dfas.parquet $(OUT)/$(1)/traces.parquet \
	    --embedder $(OUT)/$(1)/seed$(2)/meta-$(3) -o $$(@D) --label $(1) --seed $(2) \
	    --pair-features $(PAIR_FEATURES) -q
endef
$(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,syntax dfa,$(eval $(call RUN,$(t),$(s),$(e))))))

.SECONDARY:
clean:
	rm -rf $(OUT)
