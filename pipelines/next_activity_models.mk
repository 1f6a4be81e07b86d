# Next-activity prediction on REAL event logs with every tleaf model, in Rama-Maneiro, Vidal and
# Lama's benchmark (IEEE TSC 2021: 5-fold cross-validation over case ids, split-cases --folds 5;
# accuracy pooled over every prefix, the end of the case a target), model selection on
# validation only, and mined knowledge on top of the model chosen. Per log: read-log; per fold:
# split-cases, then
#   prefix-table  the trivial baseline (the next activity most often seen after the prefix);
#                 its evaluation also gives the leakage (test prefixes seen in training with
#                 their next activity) and the accuracy on the unseen ones;
#   lstm          train-task --model lstm --grid "$(LSTM_GRID)" (LSTM_GRID_<log> where set): one
#                 run per combination, the best val accuracy kept;
#   transformer   the same with --model transformer --grid "$(TRANSFORMER_GRID)"
#                 (TRANSFORMER_GRID_<log>);
#   best          whichever of the two has the higher val accuracy (metrics.json's "best";
#                 ties: lstm), written to fold<k>/best.txt: model selection across both grids
#                 on validation, never on test;
#   knowledge     mine-declare on the fold's train split, then train-task with the best run's
#                 model and chosen settings (the report's --flags), --kb mined.ltl
#                 --logic-loss exact --lambdas $(LAMBDAS) --reference <the best run>: λ chosen
#                 on val among LAMBDAS and 0, the λ-0 candidate being the best run itself;
#                 evaluated under the mined rules (eval --rules: prediction that keeps them).
# Every run is evaluated on the fold's test cases (eval next-activity); the report
# (pipelines/next_activity_models_report.py) writes the page from the runs.
#   make -f pipelines/next_activity_models.mk DATA=PATH [OUT=out/next_activity_models]
#       [LOGS="..."] [FOLDS="0 1 2 3 4"] [PAGE=FILE.md] [SMALL=1] [-j2]
# DATA: the folder of pipelines/event_logs.mk (docs/event_logs.md, "Data for the published
# comparisons": DATA/preprocessed/<log>.csv, DATA/published/accuracy_raw_results.csv); every
# input the chosen logs need is checked before anything runs; PUBLISHED= runs without the
# peers' figures. LOGS: cheapest first, so a run cut short has its small logs whole.
# The page: $(OUT)/next_activity_models.md with its record of runs beside it
# (next_activity_models.runs.json; an invocation with LOGS= some logs adds theirs to the
# others'); PAGE=docs/results/next_activity_models.md writes the repository's page and its
# record instead. SMALL=1 runs the chain on the shipped Helpdesk sample (examples/event_logs/,
# two folds, small grids, two epochs) in about a minute.
# Each training, mining and evaluation runs through pipelines/timed-tleaf (<folder>.times.tsv:
# its wall and CPU seconds; the page's wall time is the union of these commands' spans);
# a line per finished training and evaluation says what it found. One thread per run: -j2 on 2
# cores; a fold trains only once the evaluations of the fold AHEAD (default 2) places before it
# are done, so folds and logs finish in order. make tracks files, not settings: a new OUT when
# changing a grid, LAMBDAS or TASK.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
SEED ?= 0
LAMBDAS ?= 0.1,1
AHEAD ?= 2
export OMP_NUM_THREADS ?= 1

ifneq ($(findstring command line,$(origin REPORT)$(origin RUNS)),)
$(error REPORT= and RUNS= are not read: PAGE=FILE.md names the page, its record is FILE.runs.json)
endif

# the pipeline's logs, cheapest first (the count lines name these)
ALL := BPI_Challenge_2013_closed_problems env_permit Helpdesk SEPSIS \
    bpi_challenge_2013_incidents BPI_Challenge_2012_W_Complete
ifeq ($(SMALL),1)
OUT ?= out/next_activity_models-small
LOGS ?= helpdesk-400
FOLDS ?= 0 1
NFOLDS := 2
LSTM_GRID ?= hidden=8,16 layers=1
TRANSFORMER_GRID ?= hidden=8,16 layers=1
TASK := --epochs 2
ALL :=
log_csv = examples/event_logs/$(1).csv
PUBLISHED :=
else
ifndef DATA
$(error DATA=PATH is required: the downloaded logs, laid out as docs/event_logs.md says)
endif
OUT ?= out/next_activity_models
LOGS ?= $(ALL)
FOLDS ?= 0 1 2 3 4
NFOLDS := 5
LSTM_GRID ?= hidden=64,100 layers=1,2 lr=0.001,0.002
TRANSFORMER_GRID ?= hidden=36,64 layers=1,2 lr=0.001,0.002
# the two largest logs (65,000-72,000 events) on grids half as large, to fit 2 cores: the number
# of layers validation chose in most folds of the four others (LSTM 2 in 16 of 20, Transformer
# 1 in 17 of 20)
LSTM_GRID_bpi_challenge_2013_incidents ?= hidden=64,100 layers=2 lr=0.001,0.002
TRANSFORMER_GRID_bpi_challenge_2013_incidents ?= hidden=36,64 layers=1 lr=0.001,0.002
LSTM_GRID_BPI_Challenge_2012_W_Complete ?= $(LSTM_GRID_bpi_challenge_2013_incidents)
TRANSFORMER_GRID_BPI_Challenge_2012_W_Complete ?= $(TRANSFORMER_GRID_bpi_challenge_2013_incidents)
TASK :=
log_csv = $(DATA)/preprocessed/$(1).csv
PUBLISHED ?= $(DATA)/published
endif

# the page, and the record of runs it is written from, beside it
PAGE ?=
page := $(or $(PAGE),$(OUT)/next_activity_models.md)
ifeq ($(filter %.md,$(page)),)
$(error PAGE=$(PAGE): the page is a .md file (its record of runs goes beside it, .runs.json))
endif
record := $(page:.md=.runs.json)

# every input the chosen logs need, checked before anything runs (not for `make clean`)
needed := $(foreach l,$(LOGS),$(call log_csv,$(l)))
ifneq ($(filter all $(page),$(or $(MAKECMDGOALS),all)),)
needed += $(if $(PUBLISHED),$(PUBLISHED)/accuracy_raw_results.csv)
endif
source := docs/event_logs.md, "Data for the published comparisons"
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

MODELS := prefix-table lstm transformer knowledge
UNITS := $(foreach l,$(LOGS),$(foreach k,$(FOLDS),$(OUT)/$(l)/fold$(k)))
EVALS := $(foreach u,$(UNITS),$(foreach m,$(MODELS),$(u)/eval-$(m)/metrics.json))
REPORT := pipelines/next_activity_models_report.py

.PHONY: all runs clean
all: $(page)
runs: $(EVALS)

# a tleaf command whose wall and CPU seconds go to $(1).times.tsv; a training into $$(@D); after
# a step, a line on what it found (a line that fails costs no step: make goes on)
timed = rm -f $(1).times.tsv; TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$(1).times.tsv pipelines/timed-tleaf
train = $(call timed,$$(@D)) train-task next-activity
say = -@$(PYTHON) $(REPORT) $(OUT) --say $$(@D)

# make starts the jobs it meets walking the goals' prerequisites in order, so unchecked it would
# start every fold's trainings, of every log, before any choice or evaluation: a fold's trainings
# wait instead for the evaluations of the fold AHEAD places before it (order only: they never
# make it rerun). The pairs: unit n+AHEAD@@unit n.
ahead_pairs := $(filter-out @@%,$(join $(wordlist $(words x $(wordlist 1,$(AHEAD),$(UNITS))),\
    $(words $(UNITS)),$(UNITS)),$(addprefix @@,$(UNITS))))
$(foreach p,$(ahead_pairs),$(eval $(foreach m,prefix-table lstm transformer,\
    $(word 1,$(subst @@, ,$(p)))/$(m)/metrics.json): | \
    $(foreach m,$(MODELS),$(word 2,$(subst @@, ,$(p)))/eval-$(m)/metrics.json)))

define LOG
$(OUT)/$(1)/cases.parquet: $(call log_csv,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
endef
$(foreach l,$(LOGS),$(eval $(call LOG,$(l))))

# a log's grid for a model: $(1) LSTM or TRANSFORMER, $(2) the log (<MODEL>_GRID_<log>, else
# <MODEL>_GRID)
grid = $(or $($(1)_GRID_$(2)),$($(1)_GRID))
log_of = $(notdir $(patsubst %/,%,$(dir $(1))))

# one fold: $(1) its folder
define FOLD
$(1)/cases.parquet: $(dir $(1))cases.parquet
	@mkdir -p $$(@D)
	$(TLEAF) split-cases $$< --folds $(NFOLDS) --fold $(patsubst fold%,%,$(notdir $(1))) -o $$@ -q
$(1)/prefix-table/metrics.json: $(1)/cases.parquet
	$(train) $$< --model prefix-table -o $$(@D) -q
$(1)/lstm/metrics.json: $(1)/cases.parquet
	$(train) $$< --model lstm --grid "$(call grid,LSTM,$(call log_of,$(1)))" --seed $(SEED) \
	    $(TASK) -o $$(@D) -q
	$(say)
$(1)/transformer/metrics.json: $(1)/cases.parquet
	$(train) $$< --model transformer \
	    --grid "$(call grid,TRANSFORMER,$(call log_of,$(1)))" --seed $(SEED) $(TASK) \
	    -o $$(@D) -q
	$(say)
$(1)/best.txt: $(1)/lstm/metrics.json $(1)/transformer/metrics.json
	$(PYTHON) $(REPORT) --choose $(1) > $$@.tmp && mv $$@.tmp $$@
$(1)/mined.ltl: $(1)/cases.parquet
	$(call timed,$$@) mine-declare $$< -o $$@
$(1)/knowledge/metrics.json: $(1)/cases.parquet $(1)/mined.ltl $(1)/best.txt
	best=$(1)/$$$$(cat $(1)/best.txt) && flags=$$$$($(PYTHON) $(REPORT) --flags $$$$best) \
	    || exit 1; $(train) $$< $$$$flags --kb $(1)/mined.ltl --logic-loss exact --lambdas $(LAMBDAS) \
	    --seed $(SEED) $(TASK) --reference $$$$best -o $$(@D) -q
	$(say)
$(1)/eval-knowledge/metrics.json: $(1)/knowledge/metrics.json
	$(call timed,$$(@D)) eval next-activity $$(<D) $(1)/cases.parquet --rules $(1)/mined.ltl \
	    -o $$(@D) -q
	$(say)
endef
$(foreach u,$(UNITS),$(eval $(call FOLD,$(u))))

# the evaluations of the runs without knowledge: accuracy (with leakage), no rules
define EVAL
$(1)/eval-$(2)/metrics.json: $(1)/$(2)/metrics.json
	$(call timed,$$(@D)) eval next-activity $$(<D) $(1)/cases.parquet -o $$(@D) -q
	$(say)
endef
$(foreach u,$(UNITS),$(foreach m,prefix-table lstm transformer,$(eval $(call EVAL,$(u),$(m)))))

$(page): $(EVALS) $(REPORT)
	@mkdir -p $(@D)
	$(PYTHON) $(REPORT) $(OUT) -o $@ --runs $(record) $(if $(PUBLISHED),--published $(PUBLISHED)) \
	    --logs "$(LOGS)" --all "$(ALL)" --small $(SMALL) \
	    --settings '$(strip LSTM_GRID="$(LSTM_GRID)" TRANSFORMER_GRID="$(TRANSFORMER_GRID)" $(foreach l,$(LOGS),$(foreach m,LSTM TRANSFORMER,$(if $($(m)_GRID_$(l)),$(m)_GRID_$(l)="$($(m)_GRID_$(l))"))) LAMBDAS=$(LAMBDAS) SEED=$(SEED) FOLDS="$(FOLDS)")'
	@echo "$@: written from $(record)"

clean:
	rm -rf $(OUT)
