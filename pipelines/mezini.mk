# Mezini et al.'s protocol (Neuro-Symbolic Predictive Process Monitoring, Information Systems
# 2026; github axelmezini/nesy-suffix-prediction-dfa) on their REAL data, BPI 2013 closed
# problems as they prepared it (examples/knowledge-protocols/mezini-bpic13-closed/, MIT): the
# first 80 % of the cases by time train, the last 20 % test; both keep only the cases that
# satisfy their Declare model; the training log at 0 (clean), 10, 20, 30 and 40 % of its events
# relabelled, the test log clean. Suffixes from prefixes of 1-3 events, greedy and sampled at
# temperature 0.7, scored by their trace similarity and the share satisfying the model.
# Per noise level:
#   join (the training log, then the test log, as one XES: train-task reads one cases artifact
#   with train, val and test; the last VAL of the training cases by time are validation, as
#   noisy as the rest) -> read-log --split-order file
# and per noise level and seed:
#   train-task next-activity --logic-loss exact --lambdas $(LAMBDAS) (λ chosen on val
#   next-activity accuracy among those and 0; the λ-0 candidate IS the reference: the same
#   seed, no logic loss) -> the same with the tleaf loss (q trained once on the model's rules;
#   its λ-0 candidate is exact's, --reference) -> eval next-activity of EVERY candidate (so
#   the report gives the λ chosen on val and each λ of the grid) with the rules: argmax,
#   beam, sample, and each again with the rules as a hard filter -> the report
#   ($(OUT)/mezini.md, pipelines/mezini_report.py) beside their per-run figures (PUBLISHED).
#   make -f pipelines/mezini.mk [OUT=out/mezini] [SMALL=1] [NOISES="0 10 20 30 40"]
#       [SEEDS="0 1 2 3 4"] [LOSSES="exact tleaf"] [LAMBDAS=0.1,0.3,1,3,10]
#       [TLEAF_LAMBDAS=0.001,0.01,0.1] [PUBLISHED=CSV | PUBLISHED=] [-j1]
# The model: their LSTM's size and optimiser where tleaf has the option (2 layers of 100,
# no dropout, Adam lr 5e-4, batches of 64); tleaf's LSTM also reads its time features, and
# stops on val accuracy (at most 500 epochs, patience 50) where theirs runs 500-2000 epochs on
# the training loss. MAX_SUFFIX 18: their sampler stops at the test log's longest case (18
# events). The Declare model's two Not Co-Existence constraints on Accepted_Assigned, an
# activity no case of these logs has, are left out of $(OUT)/kb.decl (checked: they hold on
# every case over the logs' activities, and train-task refuses a rule naming an activity
# outside the log's vocabulary).
# Cost (one core, OMP_NUM_THREADS=1): about 2 minutes per noise level and seed, 25 of them
# (docs/results/suffix_knowledge.md); SMALL=1 runs the chain on 2 noise levels, 1 seed, 2
# epochs in about a minute. Each tleaf call's wall and CPU seconds go to $(OUT)/times.tsv
# (pipelines/timed-tleaf). make tracks files, not settings: a new OUT when changing one.
# λ values are written as %g prints them (0.1, 1, 10): train-task names its candidates so.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
DATA ?= examples/knowledge-protocols/mezini-bpic13-closed
LOSSES ?= exact tleaf
LAMBDAS ?= 0.1,0.3,1,3,10
# the tleaf loss's candidates (q's distances are in the hundreds; its folder recommends ~0.002)
TLEAF_LAMBDAS ?= 0.001,0.01,0.1
VAL ?= 0.2
PREFIXES ?= 1-3
TEMPERATURE ?= 0.7
MAX_SUFFIX ?= 18
PUBLISHED ?= $(DATA)/paper_results_bpic13_closed.csv
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
# the training log of each noise level (theirs: _01n ... _04n), the test log, the model
train_log = $(DATA)/train_80_all$(if $(filter 0,$(1)),,_0$(shell echo $$(($(1) / 10)))n).xes.gz
TEST_LOG := $(DATA)/test_20_all.xes.gz
DECL := $(DATA)/test_all_85-100.decl
LOGS := $(foreach n,$(NOISES),$(call train_log,$(n))) $(TEST_LOG)

needed := $(LOGS) $(DECL) $(PUBLISHED)
source := examples/knowledge-protocols/mezini-bpic13-closed/, docs/results/suffix_knowledge.md
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

# each seed over every noise level, then the next seed: a run cut short has every level
evals_of = $(foreach x,$(grid),$(1)/eval-exact-$(x)/metrics.json) \
    $(if $(filter tleaf,$(LOSSES)),$(foreach x,$(tleaf_grid),$(1)/eval-tleaf-$(x)/metrics.json))
UNITS := $(foreach s,$(SEEDS),$(foreach n,$(NOISES),$(OUT)/n$(n)/s$(s)))
EVALS := $(foreach u,$(UNITS),$(call evals_of,$(u)))

.PHONY: all clean
all: $(OUT)/mezini.md

timed = TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$(abspath $(OUT))/times.tsv pipelines/timed-tleaf

$(OUT)/kb.decl: $(DECL) $(LOGS)
	@mkdir -p $(@D)
	@if zcat $(LOGS) | grep -q 'value="Accepted_Assigned"'; then \
	    echo "$@: a log has Accepted_Assigned: its constraints are not vacuous here" >&2; exit 1; fi
	grep -v 'Accepted_Assigned' $< > $@

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
	    --settings 'LAMBDAS=$(LAMBDAS) TLEAF_LAMBDAS=$(TLEAF_LAMBDAS) LOSSES="$(LOSSES)" TASK="$(TASK)" MAX_SUFFIX=$(MAX_SUFFIX)' \
	    -o $@
	@echo "$@: written"

clean:
	rm -rf $(OUT)
