# What the event and case attributes of a real log are worth to next-activity prediction, in
# Rama-Maneiro et al.'s protocol (5-fold cross-validation over case ids, accuracy pooled over
# every prefix, the end a target). Their preprocessed CSVs keep activities and times only; the
# logs' own XES files keep the resource, groups, lab values, amounts. Per log: read-log of the
# XES keeping the attributes (EVENT_<log>, CASE_<log>), its cases renamed to the CSV's case ids
# (pipelines/rm_case_ids.py: the benchmark's very folds); per fold: split-cases, then one --grid
# run without the attributes (none) and one reading them (inputs: --inputs INPUTS_<log>,
# --numeric-inputs NUMERIC_<log>), the same grid (GRID, or GRID_<log>: LSTM and Transformer) and
# seed; each evaluated on the fold's test cases. Per fold the run with the higher val accuracy
# of the two is chosen (chosen.txt; model selection on validation, never test), and knowledge
# goes on top of it: rules mined on the fold's train split, the exact loss with λ chosen on val
# among LAMBDAS and 0 (the λ-0 candidate the chosen run itself), evaluated under the mined
# rules.
#   make -f pipelines/attribute_inputs.mk DATA=PATH [OUT=out/attribute_inputs] [LOGS="..."]
#       [FOLDS="0 1 2 3 4"] [PAGE=FILE.md] [SMALL=1] [-j2]
# DATA: the folder of pipelines/event_logs.mk (docs/event_logs.md, "Data for the published
# comparisons"): DATA/xes/<log>.xes.gz, DATA/preprocessed/<log>.csv and
# DATA/published/accuracy_raw_results.csv (PUBLISHED= runs without the peers' figures). SMALL=1
# runs on the shipped BPI 2013 closed problems sample (examples/knowledge-protocols/mezini-
# bpic13-closed/, its resource) in about a minute.
# The page: $(OUT)/attribute_inputs.md, or PAGE=docs/results/attribute_inputs.md. One thread
# per run: -j2 on 2 cores. make tracks files, not settings: a new OUT when changing GRID.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
SEED ?= 0
LAMBDAS ?= 0.1,1
export OMP_NUM_THREADS ?= 1

include $(dir $(lastword $(MAKEFILE_LIST)))log_attributes.mk

ALL := BPI_Challenge_2013_closed_problems env_permit Helpdesk SEPSIS \
    bpi_challenge_2013_incidents BPI_Challenge_2012_W_Complete
ifeq ($(SMALL),1)
OUT ?= out/attribute_inputs-small
LOGS ?= mezini-closed
FOLDS ?= 0 1
NFOLDS := 2
GRID ?= model=lstm,transformer hidden=8 layers=1
TASK := --epochs 2
ALL :=
log_xes = examples/knowledge-protocols/mezini-bpic13-closed/train_80_all.xes.gz
PUBLISHED :=
else
ifndef DATA
$(error DATA=PATH is required: the downloaded logs, laid out as docs/event_logs.md says)
endif
OUT ?= out/attribute_inputs
LOGS ?= $(ALL)
FOLDS ?= 0 1 2 3 4
NFOLDS := 5
GRID ?= model=lstm,transformer hidden=64 layers=1,2
# the two largest logs (65,000-72,000 events) on a grid half as large, to fit 2 cores
GRID_bpi_challenge_2013_incidents ?= model=lstm,transformer hidden=64 layers=1
GRID_BPI_Challenge_2012_W_Complete ?= $(GRID_bpi_challenge_2013_incidents)
TASK :=
log_xes = $(DATA)/xes/$(1).xes.gz
log_csv = $(DATA)/preprocessed/$(1).csv
PUBLISHED ?= $(DATA)/published
endif
PAGE ?=
page := $(or $(PAGE),$(OUT)/attribute_inputs.md)

needed := $(foreach l,$(LOGS),$(call log_xes,$(l)) $(if $(log_csv),$(call log_csv,$(l)))) \
    $(if $(PUBLISHED),$(PUBLISHED)/accuracy_raw_results.csv)
source := docs/event_logs.md, "Data for the published comparisons"
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

UNITS := $(foreach l,$(LOGS),$(foreach k,$(FOLDS),$(OUT)/$(l)/fold$(k)))
EVALS := $(foreach u,$(UNITS),$(foreach v,none inputs knowledge,$(u)/eval-$(v)/metrics.json))
REPORT := pipelines/attribute_inputs_report.py

.PHONY: all runs clean
all: $(page)
runs: $(EVALS)

train = rm -f $$(@D).times.tsv; TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$$(@D).times.tsv \
    pipelines/timed-tleaf train-task next-activity
grid = $(or $(GRID_$(1)),$(GRID))

# the XES's cases under the benchmark CSV's case ids (pipelines/rm_case_ids.py): the folds are
# the benchmark's, case for case (SMALL: the sample's own ids)
define LOG
ifeq ($(SMALL),1)
$(OUT)/$(1)/xes.parquet: $(call log_xes,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< $(call reads,$(1)) -o $$@ -q
$(OUT)/$(1)/cases.parquet: $(OUT)/$(1)/xes.parquet
	cp $$< $$@
else
$(call XES_CASES,$(OUT)/$(1),$(1))
endif
endef
$(foreach l,$(LOGS),$(eval $(call LOG,$(l))))

# one fold: $(1) the log, $(2) the fold
define FOLD
$(OUT)/$(1)/fold$(2)/cases.parquet: $(OUT)/$(1)/cases.parquet
	@mkdir -p $$(@D)
	$(TLEAF) split-cases $$< --folds $(NFOLDS) --fold $(2) -o $$@ -q
$(OUT)/$(1)/fold$(2)/none/metrics.json: $(OUT)/$(1)/fold$(2)/cases.parquet
	$(train) $$< --grid "$(call grid,$(1))" --seed $(SEED) $(TASK) -o $$(@D) -q
$(OUT)/$(1)/fold$(2)/inputs/metrics.json: $(OUT)/$(1)/fold$(2)/cases.parquet
	$(train) $$< $(call inputs,$(1)) --grid "$(call grid,$(1))" --seed $(SEED) $(TASK) -o $$(@D) -q
$(OUT)/$(1)/fold$(2)/eval-none/metrics.json $(OUT)/$(1)/fold$(2)/eval-inputs/metrics.json: \
    $(OUT)/$(1)/fold$(2)/eval-%/metrics.json: $(OUT)/$(1)/fold$(2)/%/metrics.json
	$(TLEAF) eval next-activity $$(<D) $(OUT)/$(1)/fold$(2)/cases.parquet -o $$(@D) -q
$(OUT)/$(1)/fold$(2)/chosen.txt: $(OUT)/$(1)/fold$(2)/none/metrics.json \
    $(OUT)/$(1)/fold$(2)/inputs/metrics.json
	$(PYTHON) $(REPORT) --choose $$(@D) > $$@.tmp && mv $$@.tmp $$@
$(OUT)/$(1)/fold$(2)/mined.ltl: $(OUT)/$(1)/fold$(2)/cases.parquet
	$(TLEAF) mine-declare $$< -o $$@
$(OUT)/$(1)/fold$(2)/knowledge/metrics.json: $(OUT)/$(1)/fold$(2)/cases.parquet \
    $(OUT)/$(1)/fold$(2)/mined.ltl $(OUT)/$(1)/fold$(2)/chosen.txt
	chosen=$(OUT)/$(1)/fold$(2)/$$$$(cat $(OUT)/$(1)/fold$(2)/chosen.txt) && flags=$$$$($(PYTHON) $(REPORT) \
	    --flags $$$$chosen) || exit 1; $(train) $$< $$$$flags --kb $$(word 2,$$^) \
	    --logic-loss exact --lambdas $(LAMBDAS) --seed $(SEED) $(TASK) --reference $$$$chosen \
	    -o $$(@D) -q
$(OUT)/$(1)/fold$(2)/eval-knowledge/metrics.json: $(OUT)/$(1)/fold$(2)/knowledge/metrics.json
	$(TLEAF) eval next-activity $$(<D) $(OUT)/$(1)/fold$(2)/cases.parquet \
	    --rules $(OUT)/$(1)/fold$(2)/mined.ltl -o $$(@D) -q
endef
$(foreach l,$(LOGS),$(foreach k,$(FOLDS),$(eval $(call FOLD,$(l),$(k)))))

# make starts the jobs it meets walking the goals in order, so unchecked every training would
# start before any evaluation: a fold's trainings wait for the fold before it to be evaluated
# (order only: never a reason to rerun)
$(foreach p,$(filter-out @@%,$(join $(wordlist 2,$(words $(UNITS)),$(UNITS)),$(addprefix @@,\
    $(UNITS)))),$(eval \
    $(word 1,$(subst @@, ,$(p)))/none/metrics.json $(word 1,$(subst @@, ,$(p)))/inputs/metrics.json: \
    | $(word 2,$(subst @@, ,$(p)))/eval-knowledge/metrics.json))

$(page): $(EVALS) $(REPORT)
	@mkdir -p $(@D)
	$(PYTHON) $(REPORT) $(OUT) -o $@ --logs "$(LOGS)" \
	    $(if $(PUBLISHED),--published $(PUBLISHED)) \
	    --settings 'GRID="$(GRID)" $(foreach l,$(LOGS),$(if $(GRID_$(l)),GRID_$(l)="$(GRID_$(l))")) LAMBDAS=$(LAMBDAS) SEED=$(SEED) NFOLDS=$(NFOLDS)'

clean:
	rm -rf $(OUT)
