# Next-activity and suffix prediction on REAL event logs, each comparison in its peers' protocol:
#   rm: Rama-Maneiro, Vidal, Lama (IEEE TSC 2021): 5-fold cross-validation over case ids
#       (split-cases --folds 5), next-activity accuracy pooled over every prefix, end included;
#   df: Di Francescomarino et al. (BPM 2017): first 2/3 of the cases train, last 1/3 test
#       (split-cases --protocol thirds), suffix Damerau-Levenshtein similarity from their
#       prefix lengths on the test cases that satisfy their formula (strong, weak).
# Per log (and fold): read-log -> split-cases -> mine-declare (train split) -> train-task
# next-activity --logic-loss exact --lambdas $(LAMBDAS) (λ chosen on val among those and 0; the
# λ-0 candidate IS the no-knowledge reference: the same seed, no logic loss) -> eval
# next-activity (under the mined rules; df: also under each formula) -> the report. The tleaf
# loss reads a q trained on the mined rules alone (compile-dfa --one-hot -> gen-traces ->
# train-edge -> train-meta, a minute), one per log (df) or fold (rm); its λ-0 candidate is the
# exact run's (--reference: λ 0 trains without the logic term, the same run).
#   make -f pipelines/event_logs.mk DATA=PATH [OUT=out/event_logs] [PAGE=FILE.md] [SMALL=1] [-j2]
#       [RM_LOGS="Helpdesk ..."] [DF_LOGS="helpdesk ..."] [FOLDS="0 1 2 3 4"]
# DATA: a folder laid out as docs/event_logs.md's "Data" section says (preprocessed/*.csv,
# tax-order/*.csv and formulas.tsv, published/*.csv: the logs and the peers' figures, downloaded
# once); every input the chosen logs need is checked before anything runs. A new log: its
# <Name>.csv in DATA/preprocessed/ and RM_LOGS=<Name> (published figures are looked up under the
# lower-cased name). PUBLISHED= runs without the peers' figures. SMALL=1 runs the chain on the
# shipped example (examples/event_logs/) in a minute.
# The page: $(OUT)/event_logs.md and, beside it, the record of every run measured so far
# (event_logs.runs.json; an invocation with RM_LOGS=/DF_LOGS= some logs adds theirs to the
# others'); PAGE=docs/results/event_logs.md writes the repository's page and its record instead.
# Each run uses one core: -j2 on 2 cores, and AHEAD (default 2, as -j) (log, fold) units train
# before the evaluations of the first catch up, so results come as the folds finish. make tracks
# files, not settings: a new OUT when changing LAMBDAS or TASK. Each training's wall and CPU
# seconds go to <run>.times.tsv (pipelines/timed-tleaf); a line per finished training and
# evaluation says what it found.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
LAMBDAS ?= 0.1,1
# the tleaf loss's λ candidates (q's distances are in the hundreds: its folder recommends ~0.002)
TLEAF_LAMBDAS ?= 0.001,0.01
# the knowledge's losses; each run chooses λ on val among its candidates and 0
LOSSES ?= exact tleaf
SEED ?= 0
AHEAD ?= 2
export OMP_NUM_THREADS ?= 1

ifneq ($(findstring command line,$(origin REPORT)$(origin RUNS)),)
$(error REPORT= and RUNS= are not read: PAGE=FILE.md names the page, its record is FILE.runs.json)
endif

ifeq ($(SMALL),1)
OUT ?= out/event_logs-small
RM_LOGS ?= helpdesk-400
DF_LOGS ?= helpdesk-400
FOLDS ?= 0 1
NFOLDS := 2
TASK := --epochs 3
Q := --epochs 1
rm_csv = examples/event_logs/$(1).csv
df_csv = examples/event_logs/$(1).csv
FORMULAS := examples/event_logs/formulas.tsv
PUBLISHED :=
else
ifndef DATA
$(error DATA=PATH is required: the downloaded logs, laid out as docs/event_logs.md says)
endif
OUT ?= out/event_logs
RM_ALL := Helpdesk BPI_Challenge_2012_W_Complete bpi_challenge_2013_incidents \
    BPI_Challenge_2013_closed_problems SEPSIS env_permit
DF_ALL := helpdesk bpi_12_w bpi_13_incidents env_permit bpi_11
RM_LOGS ?= $(RM_ALL)
DF_LOGS ?= $(DF_ALL)
FOLDS ?= 0 1 2 3 4
NFOLDS := 5
TASK :=
Q := --epochs 10 --max-minutes 3
rm_csv = $(DATA)/preprocessed/$(1).csv
df_csv = $(DATA)/tax-order/$(1).csv
FORMULAS := $(DATA)/tax-order/formulas.tsv
PUBLISHED ?= $(DATA)/published
endif

# the page, and the record of runs it is written from, beside it
PAGE ?=
page := $(or $(PAGE),$(OUT)/event_logs.md)
ifeq ($(filter %.md,$(page)),)
$(error PAGE=$(PAGE): the page is a .md file (its record of runs goes beside it, .runs.json))
endif
record := $(page:.md=.runs.json)

# Every input the chosen logs need, checked before anything runs (not for `make clean`)
needed := $(foreach l,$(RM_LOGS),$(call rm_csv,$(l))) $(foreach l,$(DF_LOGS),$(call df_csv,$(l))) \
    $(if $(DF_LOGS),$(FORMULAS))
ifneq ($(filter all $(page),$(or $(MAKECMDGOALS),all)),)
needed += $(if $(PUBLISHED),$(PUBLISHED)/accuracy_raw_results.csv $(PUBLISHED)/apriori_suffix_dl.csv)
endif
source := docs/event_logs.md, "Data for the published comparisons"
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

# Di Francescomarino et al.'s prefix lengths per log (formulas.tsv: from, to exclusive)
PREFIXES_helpdesk := 2-5
PREFIXES_bpi_12_w := 2-5
PREFIXES_bpi_13_incidents := 2-5
PREFIXES_env_permit := 19-22
PREFIXES_bpi_11 := 13-16
PREFIXES_helpdesk-400 := 2-5
# the formulas' log names (the example is a sample of helpdesk)
FORMULA_LOG_helpdesk-400 := helpdesk
formula_log = $(or $(FORMULA_LOG_$(1)),$(1))

# the units that train: a fold of a log (rm) or a log (df), and the evaluations of each
RM_UNITS := $(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(OUT)/rm/$(l)/fold$(k)))
DF_UNITS := $(foreach l,$(DF_LOGS),$(OUT)/df/$(l))
rm_evals = $(foreach m,none $(LOSSES),$(1)/eval-$(m)/metrics.json)
df_evals = $(foreach m,none $(LOSSES),$(foreach f,strong weak,\
    $(1)/eval-$(m)-$(f)/metrics.json $(1)/eval-$(m)-$(f)-mined/metrics.json))
RM_EVALS := $(foreach u,$(RM_UNITS),$(call rm_evals,$(u)))
DF_EVALS := $(foreach u,$(DF_UNITS),$(call df_evals,$(u)))

.PHONY: all rm df clean
all: $(page)
rm: $(RM_EVALS)
df: $(DF_EVALS)

# none: the λ-0 candidate of the exact run's choice; exact, tleaf: the run chosen on val
run_dir = $(if $(filter none,$(1)),$(2)/lambda-choice/lambda-0,$(2))
loss_dir = $(2)/$(if $(filter none,$(1)),exact,$(1))
# a training, its wall and CPU seconds in <run>.times.tsv; after a step, a line on what it found
# (a line that fails costs no step: make goes on)
train = rm -f $$(@D).times.tsv; TLEAF_BIN=$(TLEAF) TLEAF_TIMES=$$(@D).times.tsv \
    pipelines/timed-tleaf train-task next-activity
say = -@$(PYTHON) pipelines/event_logs_report.py $(OUT) --say $$(@D)

# make starts the jobs it meets walking the goals' prerequisites in order, so unchecked it would
# start every training before any evaluation: a unit's training waits instead for the
# evaluations of the unit AHEAD places before it (order only: they never make it rerun)
ahead = $(foreach p,$(filter-out @@%,$(join $(wordlist $(words x $(wordlist 1,$(AHEAD),\
    $(1))),$(words $(1)),$(1)),$(addprefix @@,$(1)))),$(eval \
    $(word 1,$(subst @@, ,$(p)))/exact/metrics.json: | $(call $(2),$(word 2,$(subst @@, ,$(p))))))
$(call ahead,$(RM_UNITS),rm_evals)
$(call ahead,$(DF_UNITS),df_evals)

# ---- Rama-Maneiro et al.: 5-fold cross-validation
define RM_LOG
$(OUT)/rm/$(1)/cases.parquet: $(call rm_csv,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
endef
$(foreach l,$(RM_LOGS),$(eval $(call RM_LOG,$(l))))

define RM_FOLD
$(OUT)/rm/$(1)/fold$(2)/cases.parquet: $(OUT)/rm/$(1)/cases.parquet
	@mkdir -p $$(@D)
	$(TLEAF) split-cases $$< --folds $(NFOLDS) --fold $(2) -o $$@ -q
$(OUT)/rm/$(1)/fold$(2)/mined.ltl: $(OUT)/rm/$(1)/fold$(2)/cases.parquet
	$(TLEAF) mine-declare $$< -o $$@
$(OUT)/rm/$(1)/fold$(2)/exact/metrics.json: $(OUT)/rm/$(1)/fold$(2)/cases.parquet \
    $(OUT)/rm/$(1)/fold$(2)/mined.ltl
	$(train) $$< --kb $$(word 2,$$^) --logic-loss exact \
	    --lambdas $(LAMBDAS) --seed $(SEED) $(TASK) -o $$(@D) -q
	$(say)
endef
$(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(eval $(call RM_FOLD,$(l),$(k)))))

define RM_EVAL
$(OUT)/rm/$(1)/fold$(2)/eval-$(3)/metrics.json: $(call loss_dir,$(3),$(OUT)/rm/$(1)/fold$(2))/metrics.json
	$(TLEAF) eval next-activity $(call run_dir,$(3),$(call loss_dir,$(3),$(OUT)/rm/$(1)/fold$(2))) \
	    $(OUT)/rm/$(1)/fold$(2)/cases.parquet --rules $(OUT)/rm/$(1)/fold$(2)/mined.ltl \
	    -o $$(@D) -q
	$(say)
endef
$(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(foreach m,none $(LOSSES),\
    $(eval $(call RM_EVAL,$(l),$(k),$(m))))))

# q on the mined rules of folder $(1), and the tleaf loss's run there on $(1)/cases.parquet
define Q_AND_TLEAF
$(1)/q/rules.parquet: $(1)/mined.ltl
	@mkdir -p $$(@D)
	$(TLEAF) compile-dfa $$< --one-hot -q -o $$@
$(1)/q/traces.parquet: $(1)/q/rules.parquet
	$(TLEAF) gen-traces $$< --one-hot --per-formula 40 --split 0.8,0.1,0.1 -q -o $$@ || [ $$$$? -eq 1 ]
$(1)/q/edge/metrics.json: $(1)/q/rules.parquet
	$(TLEAF) train-edge $$< -o $$(@D) --epochs 3 -q
$(1)/q/meta/metrics.json: $(1)/q/rules.parquet $(1)/q/traces.parquet $(1)/q/edge/metrics.json
	$(TLEAF) train-meta $(1)/q/rules.parquet $(1)/q/traces.parquet --edge $(1)/q/edge -o $$(@D) $(Q) -q
$(1)/tleaf/metrics.json: $(1)/cases.parquet $(1)/mined.ltl $(1)/q/meta/metrics.json \
    $(1)/exact/metrics.json
	$(train) $$< --kb $(1)/mined.ltl --logic-loss tleaf \
	    --embedder $(1)/q/meta --lambdas $(TLEAF_LAMBDAS) --seed $(SEED) $(TASK) \
	    --reference $(1)/exact/lambda-choice/lambda-0 -o $$(@D) -q
	$(say)
endef
$(foreach u,$(RM_UNITS) $(DF_UNITS),$(eval $(call Q_AND_TLEAF,$(u))))

# ---- Di Francescomarino et al.: first 2/3 train, last 1/3 test
define DF_LOG
$(OUT)/df/$(1)/log.parquet: $(call df_csv,$(1))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
$(OUT)/df/$(1)/cases.parquet: $(OUT)/df/$(1)/log.parquet
	$(TLEAF) split-cases $$< --protocol thirds -o $$@ -q
$(OUT)/df/$(1)/formulas.ltl: $(FORMULAS) $(OUT)/df/$(1)/cases.parquet
	$(TLEAF) peer-formulas $$< --cases $$(word 2,$$^) --log $(call formula_log,$(1)) -o $$@ -q
$(OUT)/df/$(1)/mined.ltl: $(OUT)/df/$(1)/cases.parquet
	$(TLEAF) mine-declare $$< -o $$@
$(OUT)/df/$(1)/exact/metrics.json: $(OUT)/df/$(1)/cases.parquet $(OUT)/df/$(1)/mined.ltl
	$(train) $$< --kb $$(word 2,$$^) --logic-loss exact \
	    --lambdas $(LAMBDAS) --seed $(SEED) $(TASK) -o $$(@D) -q
	$(say)
endef
$(foreach l,$(DF_LOGS),$(eval $(call DF_LOG,$(l))))

# eval-<model>-<formula>: suffixes under the formula; eval-<model>-<formula>-mined: under the
# mined rules; both on the test cases that satisfy the formula
define DF_EVAL
$(OUT)/df/$(1)/eval-$(2)-$(3)/metrics.json: $(call loss_dir,$(2),$(OUT)/df/$(1))/metrics.json \
    $(OUT)/df/$(1)/formulas.ltl
	$(TLEAF) eval next-activity $(call run_dir,$(2),$(call loss_dir,$(2),$(OUT)/df/$(1))) \
	    $(OUT)/df/$(1)/cases.parquet --rules $(OUT)/df/$(1)/formulas.ltl \
	    --rule $(call formula_log,$(1)).$(3) --scored satisfying \
	    --prefix-lengths $(PREFIXES_$(1)) -o $$(@D) -q
	$(say)
$(OUT)/df/$(1)/eval-$(2)-$(3)-mined/metrics.json: $(call loss_dir,$(2),$(OUT)/df/$(1))/metrics.json \
    $(OUT)/df/$(1)/formulas.ltl $(OUT)/df/$(1)/mined.ltl
	$(TLEAF) eval next-activity $(call run_dir,$(2),$(call loss_dir,$(2),$(OUT)/df/$(1))) \
	    $(OUT)/df/$(1)/cases.parquet --rules $(OUT)/df/$(1)/mined.ltl \
	    --scored-by $(OUT)/df/$(1)/formulas.ltl --scored-rule $(call formula_log,$(1)).$(3) \
	    --scored satisfying --prefix-lengths $(PREFIXES_$(1)) -o $$(@D) -q
	$(say)
endef
$(foreach l,$(DF_LOGS),$(foreach m,none $(LOSSES),$(foreach f,strong weak,\
    $(eval $(call DF_EVAL,$(l),$(m),$(f))))))

$(page): $(RM_EVALS) $(DF_EVALS) pipelines/event_logs_report.py
	@mkdir -p $(@D)
	$(PYTHON) pipelines/event_logs_report.py $(OUT) -o $@ $(if $(PUBLISHED),--published $(PUBLISHED)) \
	    --runs $(record) --logs "$(addprefix rm/,$(RM_LOGS)) $(addprefix df/,$(DF_LOGS))" \
	    --rm-all "$(RM_ALL)" --df-all "$(DF_ALL)" \
	    --settings 'LAMBDAS=$(LAMBDAS) TLEAF_LAMBDAS=$(TLEAF_LAMBDAS) LOSSES="$(LOSSES)" SEED=$(SEED)'
	@echo "$@: written from $(record)"

clean:
	rm -rf $(OUT)
