# Mezini et al.'s protocol (Neuro-Symbolic Predictive Process Monitoring, Information Systems
# 2026; github axelmezini/nesy-suffix-prediction-dfa) on their REAL data: by default BPI 2013
# closed problems as they prepared it (examples/knowledge-protocols/mezini-bpic13-closed/, MIT);
# their other logs (sepsis, BPIC_2020_travel) in the same layout with DATA= alone (below). The
# first 80 % of the cases by time train, the last 20 % test; both keep only the cases that
# satisfy their Declare model; the training log at 0 (clean), 10, 20, 30 and 40 % of its events
# relabelled, the test log clean. Suffixes from prefixes of PREFIXES events, greedy and
# sampled at temperature 0.7, scored by their trace similarity and the share satisfying the model.
# Per noise level:
#   join (the training log, then the test log, as one XES: train-task reads one cases artifact
#   with train, val and test; the last VAL of the training cases by time are validation, as
#   noisy as the rest) -> read-log --split-order file
# then the run's model and record (pipelines/mezini_data.py kb, below), and per noise level and
# seed:
#   train-task next-activity --logic-loss exact --lambdas $(LAMBDAS) (λ chosen on val
#   next-activity accuracy among those and 0; the λ-0 candidate IS the reference: the same
#   seed, no logic loss) -> the same with the tleaf loss (q trained once on the model's rules;
#   its λ-0 candidate is exact's, --reference) -> eval next-activity of EVERY candidate (so
#   the report gives the λ chosen on val and each λ of the grid) with the rules: argmax,
#   beam, sample, and each again with the rules as a hard filter -> the report
#   ($(OUT)/mezini.md, pipelines/mezini_report.py) beside their per-run figures (PUBLISHED).
#   make -f pipelines/mezini.mk [DATA=DIR] [OUT=out/mezini] [SMALL=1] [NOISES="0 10 20 30 40"]
#       [SEEDS="0 1 2 3 4"] [LOSSES="exact tleaf"] [LAMBDAS=0.1,0.3,1,3,10]
#       [TLEAF_LAMBDAS=0.001,0.01,0.1] [PREFIXES=1-3] [MAX_SUFFIX=18]
#       [PUBLISHED=CSV [DATASET=NAME] | PUBLISHED=] [-j1]
# DATA: a folder holding train_80_all.xes(.gz), train_80_all_0Nn.xes(.gz) for each noise level
# N0 % of NOISES (01n ... 04n), test_20_all.xes(.gz) and test_all_85-100.decl, the names of their
# repository's data/<log>/log/ and data/<log>/model/ (copy those files into one folder; gzipped
# or not), and optionally their per-run figures as paper_results*.csv (their
# results/paper_results.csv holds every log: DATASET= names the log's rows, its `dataset`
# column, e.g. sepsis). Without a CSV the report has no "their" columns.
# Taken from the data, each overridable, each written with where it came from in
# $(OUT)/record.json (which the report shows):
#   PREFIXES   their runner's prefix lengths: floor(m / 2) and the next two, m the median
#              length of the training cases (BPI 2013 closed: m = 2, 1-3); computed by
#              pipelines/mezini_data.py settings when make reads this file;
#   MAX_SUFFIX the test log's longest case: their sampler stops there (BPI 2013 closed: 18);
#   the model  $(OUT)/kb.decl is their .decl without the constraints naming an activity that no
#              case of a noise level's joined logs has (and those activities' declarations),
#              each left out constraint in the record with why, and whether it holds on every
#              case anyway (BPI 2013 closed: the two Not Co-Existence on Accepted_Assigned, which
#              do).
# The model: their LSTM's size and optimiser where tleaf has the option (2 layers of 100,
# no dropout, Adam lr 5e-4, batches of 64); tleaf's LSTM also reads its time features, and
# stops on val accuracy (at most 500 epochs, patience 50) where theirs runs 500-2000 epochs on
# the training loss.
# Cost (one core, OMP_NUM_THREADS=1): about 2 minutes per noise level and seed on BPI 2013
# closed, 25 of them (docs/results/suffix_knowledge.md); SMALL=1 runs the chain on 2 noise
# levels, 1 seed, 2 epochs in about a minute. Each tleaf call's wall and CPU seconds go to
# $(OUT)/times.tsv (pipelines/timed-tleaf). make tracks files, not settings: a new OUT when
# changing one. λ values are written as %g prints them (0.1, 1, 10): train-task names its
# candidates so.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
DATA ?= examples/knowledge-protocols/mezini-bpic13-closed
LOSSES ?= exact tleaf
LAMBDAS ?= 0.1,0.3,1,3,10
# the tleaf loss's candidates (q's distances are in the hundreds; its folder recommends ~0.002)
TLEAF_LAMBDAS ?= 0.001,0.01,0.1
VAL ?= 0.2
TEMPERATURE ?= 0.7
# their per-run figures, where DATA has them (BPI 2013 closed: paper_results_bpic13_closed.csv)
PUBLISHED ?= $(firstword $(wildcard $(DATA)/paper_results*.csv))
# the rows of PUBLISHED to read (its `dataset` column): needed where it holds several logs
DATASET ?=
export OMP_NUM_THREADS ?= 1

ifeq ($(SMALL),1)
OUT ?= out/mezini-small
NOISES ?= 0 40
SEEDS ?= 0
ifeq ($(origin LAMBDAS),file)
LAMBDAS := 1
endif
ifeq ($(origin TLEAF_LAMBDAS),file)
TLEAF_LAMBDAS := 0.01
endif
TASK := --hidden 16 --layers 2 --dropout 0 --lr 5e-4 --batch-size 64 --epochs 2 --patience 2
Q := --epochs 1
else
OUT ?= out/mezini
NOISES ?= 0 10 20 30 40
SEEDS ?= 0 1 2 3 4
TASK := --hidden 100 --layers 2 --dropout 0 --lr 5e-4 --batch-size 64 --epochs 500 --patience 50
Q := --epochs 10 --max-minutes 3
endif

comma := ,
grid = 0 $(subst $(comma), ,$(LAMBDAS))
tleaf_grid = $(subst $(comma), ,$(TLEAF_LAMBDAS))
# a log of DATA, gzipped where that file is there, else as their repository has it (.xes)
xes = $(firstword $(wildcard $(DATA)/$(1).xes.gz $(DATA)/$(1).xes) $(DATA)/$(1).xes.gz)
# the training log of each noise level (theirs: _01n ... _04n), the test log, the model
train_log = $(call xes,train_80_all$(if $(filter 0,$(1)),,_0$(shell echo $$(($(1) / 10)))n))
TEST_LOG := $(call xes,test_20_all)
DECL := $(DATA)/test_all_85-100.decl
TRAIN_LOGS := $(foreach n,$(NOISES),$(call train_log,$(n)))
LOGS := $(TRAIN_LOGS) $(TEST_LOG)

needed := $(LOGS) $(DECL) $(PUBLISHED)
source := examples/knowledge-protocols/mezini-bpic13-closed/, docs/results/suffix_knowledge.md
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

# PREFIXES and MAX_SUFFIX from the logs, as their runner takes them, unless given
ifneq ($(filter-out clean,$(or $(MAKECMDGOALS),all)),)
ifneq ($(filter undefined,$(origin PREFIXES) $(origin MAX_SUFFIX)),)
derived := $(shell $(PYTHON) pipelines/mezini_data.py settings $(TRAIN_LOGS) --test $(TEST_LOG) 2>&1)
ifneq ($(.SHELLSTATUS),0)
$(error PREFIXES and MAX_SUFFIX from the logs: $(PYTHON) pipelines/mezini_data.py settings \
    failed: $(derived) (set PYTHON=, or PREFIXES= and MAX_SUFFIX=))
endif
PREFIXES ?= $(word 1,$(derived))
MAX_SUFFIX ?= $(word 2,$(derived))
endif
endif

# each seed over every noise level, then the next seed: a run cut short has every level
evals_of = $(foreach x,$(grid),$(1)/eval-exact-$(x)/metrics.json) \
    $(if $(filter tleaf,$(LOSSES)),$(foreach x,$(tleaf_grid),$(1)/eval-tleaf-$(x)/metrics.json))
UNITS := $(foreach s,$(SEEDS),$(foreach n,$(NOISES),$(OUT)/n$(n)/s$(s)))
EVALS := $(foreach u,$(UNITS),$(call evals_of,$(u)))

.PHONY: all clean
all: $(OUT)/mezini.md

timed = TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$(abspath $(OUT))/times.tsv pipelines/timed-tleaf


# q for the tleaf loss, on the model's rules alone (as pipelines/event_logs.mk builds it)
$(OUT)/q/rules.parquet: $(OUT)/kb.decl
	@mkdir -p $(@D)
	$(TLEAF) compile-dfa $< --one-hot -q -o $@
$(OUT)/q/traces.parquet: $(OUT)/q/rules.parquet
	$(TLEAF) gen-traces $< --one-hot --per-formula 40 --split 0.8,0.1,0.1 -q -o $@ || [ $$? -eq 1 ]
$(OUT)/q/edge/metrics.json: $(OUT)/q/rules.parquet
	$(TLEAF) train-edge $< -o $(@D) --epochs 3 -q
$(OUT)/q/meta/metrics.json: $(OUT)/q/rules.parquet $(OUT)/q/traces.parquet $(OUT)/q/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/q/rules.parquet $(OUT)/q/traces.parquet --edge $(OUT)/q/edge \
	    -o $(@D) $(Q) -q

define NOISE
$(OUT)/n$(1)/joined.xes: $(call train_log,$(1)) $(TEST_LOG) | pipelines/mezini_report.py
	@mkdir -p $$(@D)
	$(PYTHON) pipelines/mezini_report.py join $$< $(TEST_LOG) --val $(VAL) -o $$@
$(OUT)/n$(1)/cases.parquet: $(OUT)/n$(1)/joined.xes
	$(TLEAF) read-log $$< -o $$@ --split $$$$(cat $(OUT)/n$(1)/joined.split) --split-order file -q
endef
$(foreach n,$(NOISES),$(eval $(call NOISE,$(n))))

# their model without the constraints over activities the logs lack; the run's record beside it
CASES := $(foreach n,$(NOISES),$(OUT)/n$(n)/cases.parquet)
$(OUT)/kb.decl: $(DECL) $(CASES) | pipelines/mezini_data.py
	$(PYTHON) pipelines/mezini_data.py kb $< $(CASES) -o $@ --record $(OUT)/record.json \
	    --train $(TRAIN_LOGS) --test $(TEST_LOG) --prefixes $(PREFIXES) --max-suffix $(MAX_SUFFIX) \
	    $(if $(PUBLISHED),--published $(PUBLISHED))$(if $(DATASET), --dataset $(DATASET))

define UNIT
$(1)/exact/metrics.json: $(2)/cases.parquet $(OUT)/kb.decl
	@mkdir -p $$(@D)
	$(timed) train-task next-activity $$< --kb $(OUT)/kb.decl --logic-loss exact \
	    --lambdas $(LAMBDAS) --seed $(3) $(TASK) -o $$(@D) -q
$(1)/tleaf/metrics.json: $(2)/cases.parquet $(OUT)/kb.decl $(OUT)/q/meta/metrics.json \
    $(1)/exact/metrics.json
	$(timed) train-task next-activity $$< --kb $(OUT)/kb.decl --logic-loss tleaf \
	    --embedder $(OUT)/q/meta --lambdas $(TLEAF_LAMBDAS) --seed $(3) $(TASK) \
	    --reference $(1)/exact/lambda-choice/lambda-0 -o $$(@D) -q
endef
$(foreach s,$(SEEDS),$(foreach n,$(NOISES),$(eval $(call UNIT,$(OUT)/n$(n)/s$(s),$(OUT)/n$(n),$(s)))))

# eval of candidate λ $(4) of loss $(3) in unit $(1) (noise folder $(2))
define EVAL
$(1)/eval-$(3)-$(4)/metrics.json: $(1)/$(3)/metrics.json
	$(timed) eval next-activity $(1)/$(3)/lambda-choice/lambda-$(4) $(2)/cases.parquet \
	    --rules $(OUT)/kb.decl --prefix-lengths $(PREFIXES) --temperature $(TEMPERATURE) \
	    --max-suffix $(MAX_SUFFIX) -o $$(@D) -q
endef
$(foreach s,$(SEEDS),$(foreach n,$(NOISES),$(foreach x,$(grid),\
    $(eval $(call EVAL,$(OUT)/n$(n)/s$(s),$(OUT)/n$(n),exact,$(x))))))
$(foreach s,$(SEEDS),$(foreach n,$(NOISES),$(foreach x,$(tleaf_grid),\
    $(eval $(call EVAL,$(OUT)/n$(n)/s$(s),$(OUT)/n$(n),tleaf,$(x))))))

$(OUT)/mezini.md: $(EVALS) pipelines/mezini_report.py
	$(PYTHON) pipelines/mezini_report.py report $(OUT) $(if $(PUBLISHED),--published $(PUBLISHED)) \
	    $(if $(DATASET),--dataset $(DATASET) )--settings 'LAMBDAS=$(LAMBDAS) TLEAF_LAMBDAS=$(TLEAF_LAMBDAS) LOSSES="$(LOSSES)" TASK="$(TASK)" PREFIXES=$(PREFIXES) MAX_SUFFIX=$(MAX_SUFFIX)' \
	    -o $@
	@echo "$@: written"

clean:
	rm -rf $(OUT)
