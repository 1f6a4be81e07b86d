# The learning curve of next-activity prediction on REAL event logs: what mined Declare rules are
# worth in training cases. Rama-Maneiro et al.'s fold FOLD (5-fold cross-validation over case
# ids, split-cases), then of its training cases only a share (SHARES, in %) kept, drawn by the
# seed (split-cases --train-share F --share-seed SEED: nested, a smaller share's cases among a
# larger one's; val and test are the fold's at every share). Per log, share and seed:
#   read-log -> split-cases --fold FOLD --train-share F --share-seed SEED -> mine-declare (the
#   kept train cases) -> train-task next-activity --logic-loss exact --lambdas LAMBDAS --seed
#   SEED (λ chosen on val among LAMBDAS and 0; the λ-0 candidate is the no-knowledge
#   reference) -> eval next-activity of the reference (eval-none) and of the chosen run
#   (eval-exact), each by argmax and under the mined rules -> the report (curve.md, curve.json:
#   pipelines/learning_curve_logs_report.py).
# Four variants: none (the reference, argmax), none under the rules, exact (argmax), exact under
# the rules; test accuracy pooled over every prefix, the end a target (Rama-Maneiro et al.'s).
# Data worth: the share the reference's curve needs for a variant's accuracy (linear on log
# share), over the variant's share.
#   make -f pipelines/learning_curve_logs.mk DATA=PATH [OUT=out/lc_logs] [SMALL=1] [-j1]
#       [LOGS="Helpdesk BPI_Challenge_2012_W_Complete SEPSIS"] [SHARES="1 3 10 30 100"]
#       [SEEDS="0 1 2 3 4"] [SEEDS_100="0 1"] [LAMBDAS=0.1,1] [FOLD=0]
# DATA: the folder of pipelines/event_logs.mk (DATA/preprocessed/<log>.csv). SEEDS_<share>
# overrides SEEDS at one share (the costliest is 100 % of BPI 2012 W). Epochs and patience: 100
# and 10 (train-task's defaults) from 10 % on; below, scaled by 10 % / share (1 %: 1000 and 100,
# 3 %: 333 and 33; EPOCHS_<share>, PATIENCE_<share> override them); and in any case a patience
# of at least PATIENCE_STEPS (90) gradient steps, batches of BATCH (32) cases, with 10 times
# that many epochs: a share of a few batches per epoch still trains past the plateau where a
# model predicts the most frequent activity (Sepsis at 3 and 10 %, with a patience of 33 and 10
# epochs of one and three batches, stopped there in 6 of 30 runs: 21-28 % test accuracy).
# Order: share by share, then seed by seed, then log (-j1 finishes the small shares first; a run
# cut short has its small shares whole). Cost on one core of a shared 2-core host
# (OMP_NUM_THREADS=1, -j1): about 105 minutes for the three logs, five seeds at every share, 100 %
# a third of it (docs/results/learning_curve_logs.md).
# Each training's wall and CPU seconds go to <unit>/times.tsv (pipelines/timed-tleaf). SMALL=1
# runs the chain on the shipped Helpdesk sample (examples/event_logs/) in about a minute.
# make tracks files, not settings: a new OUT when changing LAMBDAS, FOLD or the epochs.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
LAMBDAS ?= 0.1,1
FOLD ?= 0
export OMP_NUM_THREADS ?= 1

ifeq ($(SMALL),1)
OUT ?= out/lc_logs-small
LOGS ?= helpdesk-400
SHARES ?= 10 100
SEEDS ?= 0 1
log_csv = examples/event_logs/$(1).csv
TASK := --hidden 16 --layers 1
EPOCHS_DEFAULT := 3
PATIENCE_DEFAULT := 2
PATIENCE_STEPS := 1
EPOCHS_PER_PATIENCE := 1
else
ifndef DATA
$(error DATA=PATH is required: the folder of pipelines/event_logs.mk (DATA/preprocessed/<log>.csv))
endif
OUT ?= out/lc_logs
LOGS ?= Helpdesk BPI_Challenge_2012_W_Complete SEPSIS
SHARES ?= 1 3 10 30 100
SEEDS ?= 0 1 2 3 4
log_csv = $(DATA)/preprocessed/$(1).csv
TASK :=
EPOCHS_DEFAULT := 100
PATIENCE_DEFAULT := 10
EPOCHS_1 ?= 1000
PATIENCE_1 ?= 100
EPOCHS_3 ?= 333
PATIENCE_3 ?= 33
PATIENCE_STEPS ?= 90
EPOCHS_PER_PATIENCE ?= 10
endif
BATCH ?= 32

needed := $(foreach l,$(LOGS),$(call log_csv,$(l)))
source := docs/event_logs.md, "Data for the published comparisons"
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

# a share in % as the fraction split-cases reads; the seeds, epochs and patience of a share
fraction = $(shell awk 'BEGIN { printf "%g", $(1) / 100 }')
seeds_of = $(or $(SEEDS_$(1)),$(SEEDS))
epochs_of = $(or $(EPOCHS_$(1)),$(EPOCHS_DEFAULT))
patience_of = $(or $(PATIENCE_$(1)),$(PATIENCE_DEFAULT))
# the train cases of a cases artifact (its path the first argument)
count_train = import sys, pyarrow.parquet as pq; \
    print(pq.read_table(sys.argv[1], columns=['split']).column('split').to_pylist().count('train'))
# every unit (log, share, seed), share by share, then seed, then log
UNITS := $(foreach s,$(SHARES),$(foreach k,$(call seeds_of,$(s)),$(foreach l,$(LOGS),\
    $(OUT)/$(l)/p$(s)/s$(k))))
EVALS := $(foreach u,$(UNITS),$(u)/eval-none/metrics.json $(u)/eval-exact/metrics.json)

.PHONY: all runs clean
all: $(OUT)/curve.md
runs: $(EVALS)

define LOG
$(OUT)/$(1)/cases.parquet: $(call log_csv,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
endef
$(foreach l,$(LOGS),$(eval $(call LOG,$(l))))

# one unit: log $(1), share $(2) %, seed $(3)
define UNIT
$(OUT)/$(1)/p$(2)/s$(3)/cases.parquet: $(OUT)/$(1)/cases.parquet
	@mkdir -p $$(@D)
	$(TLEAF) split-cases $$< --fold $(FOLD) \
	    $(if $(filter 100,$(2)),,--train-share $(call fraction,$(2)) --share-seed $(3)) -o $$@ -q
$(OUT)/$(1)/p$(2)/s$(3)/mined.ltl: $(OUT)/$(1)/p$(2)/s$(3)/cases.parquet
	$(TLEAF) mine-declare $$< -o $$@ -q
$(OUT)/$(1)/p$(2)/s$(3)/exact/metrics.json: $(OUT)/$(1)/p$(2)/s$(3)/cases.parquet \
    $(OUT)/$(1)/p$(2)/s$(3)/mined.ltl
	rm -f $(OUT)/$(1)/p$(2)/s$(3)/times.tsv
	n=$$$$($(PYTHON) -c "$$(count_train)" $$<); b=$$$$(( (n + $(BATCH) - 1) / $(BATCH) )); \
	p=$$$$(( ($(PATIENCE_STEPS) + b - 1) / b )); p=$$$$(( p > $(call patience_of,$(2)) ? p : $(call patience_of,$(2)) )); \
	e=$$$$(( $(EPOCHS_PER_PATIENCE) * p )); e=$$$$(( e > $(call epochs_of,$(2)) ? e : $(call epochs_of,$(2)) )); \
	TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$(OUT)/$(1)/p$(2)/s$(3)/times.tsv pipelines/timed-tleaf train-task \
	    next-activity $$< --kb $$(word 2,$$^) --logic-loss exact --lambdas $(LAMBDAS) \
	    --seed $(3) --batch-size $(BATCH) --epochs $$$$e --patience $$$$p $(TASK) -o $$(@D) -q
$(OUT)/$(1)/p$(2)/s$(3)/eval-none/metrics.json: $(OUT)/$(1)/p$(2)/s$(3)/exact/metrics.json
	$(TLEAF) eval next-activity $$(<D)/lambda-choice/lambda-0 $$(<D)/../cases.parquet \
	    --rules $$(<D)/../mined.ltl -o $$(@D) -q
$(OUT)/$(1)/p$(2)/s$(3)/eval-exact/metrics.json: $(OUT)/$(1)/p$(2)/s$(3)/exact/metrics.json
	$(TLEAF) eval next-activity $$(<D) $$(<D)/../cases.parquet \
	    --rules $$(<D)/../mined.ltl -o $$(@D) -q
endef
$(foreach s,$(SHARES),$(foreach k,$(call seeds_of,$(s)),$(foreach l,$(LOGS),\
    $(eval $(call UNIT,$(l),$(s),$(k))))))

# the page's command: the settings that differ per share
overrides = $(strip $(foreach s,$(SHARES),$(if $(SEEDS_$(s)),SEEDS_$(s)="$(SEEDS_$(s))")))
$(OUT)/curve.md: $(EVALS) pipelines/learning_curve_logs_report.py
	$(PYTHON) pipelines/learning_curve_logs_report.py $(OUT) -o $@ --logs "$(LOGS)" \
	    --command 'make -f pipelines/learning_curve_logs.mk DATA=PATH LOGS="$(LOGS)" SHARES="$(SHARES)" SEEDS="$(SEEDS)"$(if $(overrides), $(overrides)) LAMBDAS=$(LAMBDAS) FOLD=$(FOLD)'

clean:
	rm -rf $(OUT)
