# The paper's Fig. 4B on SYNTHETIC activities: gen-activities -> kb-extract ->
# gen-traces --once-each -> train-edge -> train-meta -> train-task (models x losses x seeds) ->
# eval. Why --once-each, q's options and the lambdas: docs/results/action_recognition.md.
# Re-runs only what changed; `make -j` runs the training runs in parallel.
#   make -f pipelines/action_recognition.mk [TLEAF=tleaf] [SMALL=1] [JOBS=2] [SEEDS="0 1"]
# SMALL=1: the whole chain on a tiny synthetic set in about a minute (used by the tests).
TLEAF ?= tleaf
JOBS ?= 2
SMALL ?= 0
LOSSES ?= none tleaf exact checker
# lambda per loss (chosen on val accuracy, docs/results/action_recognition.md); none and checker
# have no gradient, their lambda changes nothing. tleaf: 0.002 (mean val accuracy of seeds 0-1,
# both models, over 0.002 / 0.006 / 0.02); LAMBDA_tleaf= (empty) uses the λ q's folder
# recommends (train-meta: 1 / q's satisfy/violate boundary, about 0.002 for this q)
LAMBDA_tleaf ?= 0.002
LAMBDA_exact ?= 1
LAMBDA_none ?= 1
LAMBDA_checker ?= 1
# where tleaf's rule sets come from: predictions (the paper) or labels
FORMULA_FROM ?= predictions
# test videos decoded with argmax, and (constrained) also under the KB's rules; the report has both
DECODE ?= constrained
DECODE_TOP_K ?= 5
# one torch thread per process: the models are small, and `make -j` runs several at once
OMP_NUM_THREADS ?= 1
export OMP_NUM_THREADS

# q_m: train-meta's default (preset best: monitors over each rule set's first 10 atoms, their
# naive-Bayes evidence, directed messages, runs readout, one radius, cosine schedule) with the
# options this pipeline's figures were measured with: rule sets' traces read up to 20 letters
# (--max-length 20), --pull 0.02, monitor shares over all lengths together (--monitor-ranges 1),
# the learned part not on the sphere (--no-sphere), early stop after 5 epochs
Q := --max-length 20 --pull 0.02 --monitor-ranges 1 --no-sphere --patience 5

ifeq ($(SMALL),1)
OUT ?= out/action-recognition-small
SEEDS ?= 0
MODELS ?= lstm tcn
DATA := --actions 6 --ingredients 8 --feature-dim 16 --train 16 --val 8 --test 16 --max-steps 8
K := 4
EDGE := --epochs 1 --hidden 32 --out-dim 16
META := --epochs 1 --hidden 32 --layers 2 --out-dim 16 $(Q)
TASK := --epochs 2 --hidden 16
else
OUT ?= out/action-recognition
SEEDS ?= 0 1 2 3 4
MODELS ?= lstm tcn
DATA :=
K := 20
EDGE := --epochs 5
META := --epochs 15 $(Q)
TASK := --epochs 150 --patience 20 --lr 1e-3
endif

RUNS := $(foreach m,$(MODELS),$(foreach l,$(LOSSES),$(foreach s,$(SEEDS),\
	$(OUT)/runs/$(m)-$(l)-seed$(s)/metrics.json)))

.PHONY: all clean
all: $(OUT)/report/report.md

# synthetic videos and the knowledge base that generated them
# one command writes both (a grouped target: with `kb.ltl: activities.parquet ;` the KB, written
# first, looked older than the videos and a finished pipeline re-ran every stage)
$(OUT)/activities.parquet $(OUT)/kb.ltl &:
	@mkdir -p $(@D)
	$(TLEAF) gen-activities -o $(OUT)/activities.parquet --kb-out $(OUT)/kb.ltl $(DATA) --seed 0 -q

# q's training data: each video's rule set (labelled pairs), and every KB rule on its own so that
# q_e knows every atom a prediction can bring in (affordance rules name pairs no video shows)
$(OUT)/kb/dfas.parquet: $(OUT)/kb.ltl $(OUT)/activities.parquet
	$(TLEAF) kb-extract $^ -o $(@D) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q
$(OUT)/rules.parquet: $(OUT)/kb.ltl
	$(TLEAF) compile-dfa $< --one-hot --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q -o $@
# traces shaped like the videos: each atom of a rule set once (+ a few "none" steps); exit
# status 1 = some rule set is short of K pairs (the empty set `true` has no violating trace, a
# two-atom set has two orders); the traces of the others are written and used
$(OUT)/traces.parquet: $(OUT)/kb/dfas.parquet
	$(TLEAF) gen-traces $< --once-each --per-formula $(K) --split 0.8,0.1,0.1 --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q \
	    -o $@ || [ $$? -eq 1 ]
$(OUT)/edge/metrics.json: $(OUT)/rules.parquet
	$(TLEAF) train-edge $< -o $(@D) $(EDGE) -q
$(OUT)/meta/metrics.json: $(OUT)/kb/dfas.parquet $(OUT)/traces.parquet $(OUT)/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/kb/dfas.parquet $(OUT)/traces.parquet --edge $(OUT)/edge \
	    -o $(@D) $(META) -q

# target models: one run per model, loss and seed; only tleaf needs q
define RUN
$(OUT)/runs/$(1)-$(2)-seed$(3)/metrics.json: $(OUT)/activities.parquet $(OUT)/kb.ltl \
    $(if $(filter tleaf,$(2)),$(OUT)/meta/metrics.json)
	$(TLEAF) train-task action-recognition $(OUT)/activities.parquet --kb $(OUT)/kb.ltl \
	    $(if $(filter tleaf,$(2)),--embedder $(OUT)/meta --formula-from $(FORMULA_FROM)) \
	    --model $(1) --logic-loss $(2) $(if $(LAMBDA_$(2)),--lambda $(LAMBDA_$(2))) --seed $(3) $(TASK) \
	    --decode $(DECODE) $(if $(filter constrained,$(DECODE)),--decode-top-k $(DECODE_TOP_K)) \
	    -o $$(@D) -q
endef
$(foreach m,$(MODELS),$(foreach l,$(LOSSES),$(foreach s,$(SEEDS),\
	$(eval $(call RUN,$(m),$(l),$(s))))))

$(OUT)/report/report.md: $(RUNS)
	$(TLEAF) eval action-recognition $(dir $^) -o $(@D) -q

# no .SECONDARY: every rule here is explicit, and with .SECONDARY a finished report would hide
# runs added later (a missing secondary prerequisite does not make its parent out of date)
clean:
	rm -rf $(OUT)
