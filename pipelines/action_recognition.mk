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
# have no gradient, their lambda changes nothing (none given). tleaf: 0.002 (mean val accuracy
# of seeds 0-1, both models, over 0.002 / 0.006 / 0.02 and no logic loss); LAMBDA_tleaf= (empty)
# uses the λ q's folder recommends (train-meta: 1 / q's satisfy/violate boundary, about 0.002
# for this q). A list (LAMBDA_exact="0.3 1 3") is chosen on val by every run itself among its
# values and 0, no logic loss (train-task --lambdas; the candidates under the run's lambda-choice/)
LAMBDA_tleaf ?= 0.002
LAMBDA_exact ?= 1
LAMBDA_none ?=
LAMBDA_checker ?=
lambda_flag = $(if $(word 2,$(1)),--lambdas "$(strip $(1))",$(if $(1),--lambda $(1)))
# where tleaf's rule sets come from: predictions (the paper) or labels
FORMULA_FROM ?= predictions
# test videos decoded with argmax, and (constrained) also under the KB's rules; the report has both
DECODE ?= constrained
DECODE_TOP_K ?= 5
# one torch thread per process: the models are small, and `make -j` runs several at once
OMP_NUM_THREADS ?= 1
export OMP_NUM_THREADS

ifeq ($(SMALL),1)
OUT ?= out/action-recognition-small
SEEDS ?= 0
MODELS ?= lstm tcn
DATA := --actions 6 --ingredients 8 --feature-dim 16 --train 16 --val 8 --test 16 --max-steps 8
TASK := --epochs 2 --hidden 16
else
OUT ?= out/action-recognition
SEEDS ?= 0 1 2 3 4
MODELS ?= lstm tcn
DATA :=
# train-task's defaults (preset best: lr 1e-3, up to 150 epochs, early stop after 20)
TASK :=
endif

RUNS := $(foreach m,$(MODELS),$(foreach l,$(LOSSES),$(foreach s,$(SEEDS),\
	$(OUT)/runs/$(m)-$(l)-seed$(s)/metrics.json)))

.PHONY: all clean
all: $(OUT)/report/report.md

# the videos, their knowledge base and q (gen-activities ... train-meta): shared with
# learning_curve.mk
include $(dir $(lastword $(MAKEFILE_LIST)))activities_q.mk

# target models: one run per model, loss and seed; only tleaf needs q
define RUN
$(OUT)/runs/$(1)-$(2)-seed$(3)/metrics.json: $(OUT)/activities.parquet $(OUT)/kb.ltl \
    $(if $(filter tleaf,$(2)),$(OUT)/meta/metrics.json)
	$(TLEAF) train-task action-recognition $(OUT)/activities.parquet --kb $(OUT)/kb.ltl \
	    $(if $(filter tleaf,$(2)),--embedder $(OUT)/meta --formula-from $(FORMULA_FROM)) \
	    --model $(1) --logic-loss $(2) $(call lambda_flag,$(LAMBDA_$(2))) --seed $(3) $(TASK) \
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
