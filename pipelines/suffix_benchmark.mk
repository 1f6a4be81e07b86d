# Suffix prediction on REAL event logs in Rama-Maneiro, Vidal and Lama's benchmark (IEEE TSC 2021;
# their repository ERamaM/PMDLComparator, tax/code/train.py --test_suffix): 5-fold
# cross-validation over case ids (split-cases --folds 5, the folds of next_activity_models.mk),
# from every prefix of 1 .. n-1 events of each test case the rest of the case predicted up to
# the log's longest case, scored by the Damerau-Levenshtein similarity of the predicted and the
# true suffix (neither with an end symbol), the mean over every (case, prefix) pair pooled.
# Per log: read-log, the longest case; per fold: split-cases, then
#   run         train-task next-activity at its defaults (Tax et al.'s LSTM; the LSTM because
#               the search advances it one event per step, lstm_calls.py);
#   mined.ltl   mine-declare on the fold's train split (the rules for the ways under them);
#   val, test   eval next-activity on the validation, then the test split, every way at once:
#               argmax, beam (width BEAM), mbr (minimum Bayes risk over SAMPLES draws), and the
#               same three under the mined rules (argmax_rules, rules, mbr_rules).
# The report (pipelines/suffix_benchmark_report.py) chooses per fold the way with the best pooled
# DL similarity on validation and reports its test figure beside every way's and the published
# approaches' (DATA/published/suffix_full_results.csv).
#   make -f pipelines/suffix_benchmark.mk DATA=PATH [OUT=out/suffix_benchmark] [LOGS="..."]
#       [FOLDS="0 1 2 3 4"] [SAMPLES=32] [BEAM=3] [RULES=1] [INPUTS=0] [PAGE=FILE.md]
#       [SMALL=1] [-j2]
# RULES=0: no mined rules, the three ways without them (half the evaluation's time). INPUTS=1:
# the model reads the attributes the CSVs drop (pipelines/log_attributes.mk: the log's XES
# under the CSV's case ids, pipelines/rm_case_ids.py, so the folds stay the benchmark's; as
# pipelines/attribute_inputs.mk), OUT defaulting to out/suffix_benchmark-inputs.
# DATA: the folder of pipelines/event_logs.mk (docs/event_logs.md, "Data for the published
# comparisons"). SMALL=1 runs the chain on the shipped Helpdesk sample (two folds, two epochs).
# make tracks files, not settings: a new OUT when changing SAMPLES, BEAM or the training.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
SEED ?= 0
SAMPLES ?= 32
BEAM ?= 3
RULES ?= 1
INPUTS ?= 0
export OMP_NUM_THREADS ?= 1

ALL := BPI_Challenge_2013_closed_problems env_permit Helpdesk SEPSIS \
    bpi_challenge_2013_incidents BPI_Challenge_2012_W_Complete
ifeq ($(SMALL),1)
OUT ?= out/suffix_benchmark-small
LOGS ?= helpdesk-400
FOLDS ?= 0 1
NFOLDS := 2
TASK := --epochs 2 --hidden 16 --layers 1
SAMPLES := 4
ALL :=
log_csv = examples/event_logs/$(1).csv
PUBLISHED :=
else
ifndef DATA
$(error DATA=PATH is required: the downloaded logs, laid out as docs/event_logs.md says)
endif
OUT ?= out/suffix_benchmark$(if $(filter 1,$(INPUTS)),-inputs)
LOGS ?= $(ALL)
FOLDS ?= 0 1 2 3 4
NFOLDS := 5
TASK :=
log_csv = $(DATA)/preprocessed/$(1).csv
log_xes = $(DATA)/xes/$(1).xes.gz
PUBLISHED ?= $(DATA)/published/suffix_full_results.csv
endif
include $(dir $(lastword $(MAKEFILE_LIST)))log_attributes.mk
read_inputs := $(filter 1,$(INPUTS))

PAGE ?=
page := $(or $(PAGE),$(OUT)/suffix_benchmark.md)
needed := $(foreach l,$(LOGS),$(call log_csv,$(l)) $(if $(read_inputs),$(call log_xes,$(l)))) \
    $(PUBLISHED)
source := docs/event_logs.md, "Data for the published comparisons"
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

REPORT := pipelines/suffix_benchmark_report.py
UNITS := $(foreach l,$(LOGS),$(foreach k,$(FOLDS),$(OUT)/$(l)/fold$(k)))
EVALS := $(foreach u,$(UNITS),$(u)/val/metrics.json $(u)/test/metrics.json)

.PHONY: all runs clean
all: $(page)
runs: $(EVALS)

timed = rm -f $(1).times.tsv; TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$(1).times.tsv pipelines/timed-tleaf

define LOG
ifeq ($(read_inputs),)
$(OUT)/$(1)/cases.parquet: $(call log_csv,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
else
$(call XES_CASES,$(OUT)/$(1),$(1))
endif
$(OUT)/$(1)/longest.txt: $(OUT)/$(1)/cases.parquet
	$(PYTHON) $(REPORT) --longest $$< > $$@.tmp && mv $$@.tmp $$@
endef
$(foreach l,$(LOGS),$(eval $(call LOG,$(l))))

# an evaluation of the fold $(1) on the split $(2): every prefix with an event after it, the cap
# the log's longest case
define EVAL
$(1)/$(2)/metrics.json: $(1)/run/metrics.json $(if $(RULES:0=),$(1)/mined.ltl) \
    $(dir $(1))longest.txt
	n=$$$$(cat $(dir $(1))longest.txt) && $(call timed,$$(@D)) eval next-activity $(1)/run \
	    $(1)/cases.parquet --split $(2) $(if $(RULES:0=),--rules $(1)/mined.ltl) \
	    --prefix-lengths 1-$$$$((n - 1)) \
	    --min-suffix 1 --max-suffix $$$$n --beam-width $(BEAM) --mbr-samples $(SAMPLES) \
	    -o $$(@D) -q
endef

log_of = $(notdir $(patsubst %/,%,$(dir $(1))))
define FOLD
$(1)/cases.parquet: $(dir $(1))cases.parquet
	@mkdir -p $$(@D)
	$(TLEAF) split-cases $$< --folds $(NFOLDS) --fold $(patsubst fold%,%,$(notdir $(1))) -o $$@ -q
$(1)/run/metrics.json: $(1)/cases.parquet
	$(call timed,$$(@D)) train-task next-activity $$< --model lstm --seed $(SEED) $(TASK) \
	    $(if $(read_inputs),$(call inputs,$(call log_of,$(1)))) -o $$(@D) -q
$(1)/mined.ltl: $(1)/cases.parquet
	$(TLEAF) mine-declare $$< -o $$@
$(call EVAL,$(1),val)
$(call EVAL,$(1),test)
endef
$(foreach u,$(UNITS),$(eval $(call FOLD,$(u))))

$(page): $(EVALS) $(REPORT)
	@mkdir -p $(@D)
	$(PYTHON) $(REPORT) $(OUT) -o $@ --logs "$(LOGS)" $(if $(PUBLISHED),--published $(PUBLISHED)) \
	    --command 'make -f pipelines/suffix_benchmark.mk DATA=PATH $(strip LOGS="$(LOGS)" \
	    FOLDS="$(FOLDS)" SAMPLES=$(SAMPLES) BEAM=$(BEAM) RULES=$(RULES) INPUTS=$(INPUTS) SEED=$(SEED))$(if $(filter 1,$(SMALL)), SMALL=1)'

clean:
	rm -rf $(OUT)
