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
#   make -f pipelines/event_logs.mk DATA=PATH [OUT=out/event_logs] [SMALL=1] [-j2]
# DATA: a folder laid out as docs/event_logs.md's "Data" section says (preprocessed/*.csv,
# tax-order/*.csv and formulas.tsv, published/*.csv: the logs and the peers' figures, downloaded
# once); SMALL=1 runs the chain on the shipped example (examples/event_logs/) in a minute.
# Each run uses one core: -j2 on 2 cores. make tracks files, not settings: a new OUT when
# changing LAMBDAS or TASK. The report is written from RUNS (every run measured so far, on
# this code: an invocation with RM_LOGS=/DF_LOGS= some logs adds theirs to the others').
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
LAMBDAS ?= 0.1,1
# the tleaf loss's λ candidates (q's distances are in the hundreds: its folder recommends ~0.002)
TLEAF_LAMBDAS ?= 0.001,0.01
# the knowledge's losses; each run chooses λ on val among its candidates and 0
LOSSES ?= exact tleaf
SEED ?= 0
export OMP_NUM_THREADS ?= 1

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
REPORT ?= $(OUT)/event_logs.md
RUNS ?= $(OUT)/runs.json
else
ifndef DATA
$(error DATA=PATH is required: the downloaded logs, laid out as docs/event_logs.md says)
endif
OUT ?= out/event_logs
RM_ALL := Helpdesk BPI_Challenge_2012_W_Complete bpi_challenge_2013_incidents \
    BPI_Challenge_2013_closed_problems SEPSIS env_permit
RM_LOGS ?= $(RM_ALL)
DF_LOGS ?= helpdesk bpi_12_w bpi_13_incidents env_permit bpi_11
FOLDS ?= 0 1 2 3 4
NFOLDS := 5
TASK :=
Q := --epochs 10 --max-minutes 3
rm_csv = $(DATA)/preprocessed/$(1).csv
df_csv = $(DATA)/tax-order/$(1).csv
FORMULAS := $(DATA)/tax-order/formulas.tsv
PUBLISHED := --published $(DATA)/published
REPORT ?= docs/results/event_logs.md
# every run's figures, kept beside the page: invocations on some logs add to the others'
RUNS ?= docs/results/event_logs.runs.json
endif

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

RM_EVALS := $(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(foreach m,none $(LOSSES),\
    $(OUT)/rm/$(l)/fold$(k)/eval-$(m)/metrics.json)))
DF_EVALS := $(foreach l,$(DF_LOGS),$(foreach m,none $(LOSSES),$(foreach f,strong weak,\
    $(OUT)/df/$(l)/eval-$(m)-$(f)/metrics.json $(OUT)/df/$(l)/eval-$(m)-$(f)-mined/metrics.json)))

.PHONY: all rm df clean
all: $(REPORT)
rm: $(RM_EVALS)
df: $(DF_EVALS)

# none: the λ-0 candidate of the exact run's choice; exact, tleaf: the run chosen on val
run_dir = $(if $(filter none,$(1)),$(2)/lambda-choice/lambda-0,$(2))
loss_dir = $(2)/$(if $(filter none,$(1)),exact,$(1))

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
	$(TLEAF) mine-declare $$< -o $$@ -q
$(OUT)/rm/$(1)/fold$(2)/exact/metrics.json: $(OUT)/rm/$(1)/fold$(2)/cases.parquet \
    $(OUT)/rm/$(1)/fold$(2)/mined.ltl
	$(TLEAF) train-task next-activity $$< --kb $$(word 2,$$^) --logic-loss exact \
	    --lambdas $(LAMBDAS) --seed $(SEED) $(TASK) -o $$(@D) -q
endef
$(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(eval $(call RM_FOLD,$(l),$(k)))))

define RM_EVAL
$(OUT)/rm/$(1)/fold$(2)/eval-$(3)/metrics.json: $(call loss_dir,$(3),$(OUT)/rm/$(1)/fold$(2))/metrics.json
	$(TLEAF) eval next-activity $(call run_dir,$(3),$(call loss_dir,$(3),$(OUT)/rm/$(1)/fold$(2))) \
	    $(OUT)/rm/$(1)/fold$(2)/cases.parquet --rules $(OUT)/rm/$(1)/fold$(2)/mined.ltl \
	    -o $$(@D) -q
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
	$(TLEAF) train-task next-activity $$< --kb $(1)/mined.ltl --logic-loss tleaf \
	    --embedder $(1)/q/meta --lambdas $(TLEAF_LAMBDAS) --seed $(SEED) $(TASK) \
	    --reference $(1)/exact/lambda-choice/lambda-0 -o $$(@D) -q
endef
$(foreach l,$(RM_LOGS),$(foreach k,$(FOLDS),$(eval $(call Q_AND_TLEAF,$(OUT)/rm/$(l)/fold$(k)))))
$(foreach l,$(DF_LOGS),$(eval $(call Q_AND_TLEAF,$(OUT)/df/$(l))))

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
	$(TLEAF) mine-declare $$< -o $$@ -q
$(OUT)/df/$(1)/exact/metrics.json: $(OUT)/df/$(1)/cases.parquet $(OUT)/df/$(1)/mined.ltl
	$(TLEAF) train-task next-activity $$< --kb $$(word 2,$$^) --logic-loss exact \
	    --lambdas $(LAMBDAS) --seed $(SEED) $(TASK) -o $$(@D) -q
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
$(OUT)/df/$(1)/eval-$(2)-$(3)-mined/metrics.json: $(call loss_dir,$(2),$(OUT)/df/$(1))/metrics.json \
    $(OUT)/df/$(1)/formulas.ltl $(OUT)/df/$(1)/mined.ltl
	$(TLEAF) eval next-activity $(call run_dir,$(2),$(call loss_dir,$(2),$(OUT)/df/$(1))) \
	    $(OUT)/df/$(1)/cases.parquet --rules $(OUT)/df/$(1)/mined.ltl \
	    --scored-by $(OUT)/df/$(1)/formulas.ltl --scored-rule $(call formula_log,$(1)).$(3) \
	    --scored satisfying --prefix-lengths $(PREFIXES_$(1)) -o $$(@D) -q
endef
$(foreach l,$(DF_LOGS),$(foreach m,none $(LOSSES),$(foreach f,strong weak,\
    $(eval $(call DF_EVAL,$(l),$(m),$(f))))))

$(REPORT): $(RM_EVALS) $(DF_EVALS) pipelines/event_logs_report.py
	@mkdir -p $(@D)
	$(PYTHON) pipelines/event_logs_report.py $(OUT) -o $@ $(PUBLISHED) --runs $(RUNS) \
	    --logs "$(addprefix rm/,$(RM_LOGS)) $(addprefix df/,$(DF_LOGS))" \
	    --rm-all "$(RM_ALL)" \
	    --settings 'LAMBDAS=$(LAMBDAS) TLEAF_LAMBDAS=$(TLEAF_LAMBDAS) LOSSES="$(LOSSES)" SEED=$(SEED)'

clean:
	rm -rf $(OUT)
