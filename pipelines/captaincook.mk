# CaptainCook4D: real recordings checked against their recipes' task graphs, and step
# recognition along the real step orders (docs/procedures.md). From the files shipped in
# examples/captaincook4d (or DATA=<a copy of github.com/CaptainCook4D/annotations>):
#   task-graph -> read-recordings -> check-recordings (the exact rule check)
#   -> recording-activities (the recordings as step sequences with drawn features, the graphs'
#      rules over the steps) -> (tleaf: a q on the rules of kb.ltl: compile-dfa --one-hot ->
#      gen-traces -> train-edge -> train-meta, one for the whole knowledge base, about a minute)
#   -> train-task action-recognition x LOSSES x SIZES x SEEDS (first N train recordings; the
#      same val and test recordings throughout; each logic loss chooses λ on val among
#      LAMBDAS_<loss> and 0, its λ-0 candidate the `none` run of the same size and seed; each
#      test set decoded by argmax and under the rules) -> eval step-recognition (argmax /
#      constrained / soft, soft's weight chosen on val, on the test recordings that keep and that
#      break their rules) and eval learning-curve --measure pair (step accuracy: a step right
#      when its node and recipe are; what the rules are worth in recordings) -> the results page.
#   make -f pipelines/captaincook.mk [TLEAF=tleaf] [SMALL=1] [OUT=out/captaincook]
#        [SIZES="10 20 40 80 213"] [SEEDS="0 1 2 3 4"] [LOSSES="none exact tleaf"]
#        [LAMBDAS_exact="0.1 1"] [LAMBDAS_tleaf="0.002 0.02"] [NOISE=2] [SIZES_tleaf="10 20 40"] [SEEDS_tleaf="0 1 2"] -j2
#   `make ... curve-page`: the curve alone, the page's Table I sections kept as they are.
# Table I on real traces (docs/procedures.md): recipe-formulas (one formula per recipe, the
#   conjunction of its rules) -> compile-dfa --one-hot -> gen-traces --split (synthetic traces;
#   the split holds recipes out) -> train-edge -> train-meta per preset (T1_PRESETS) ->
#   recording-traces (train/val: the synthetic traces; test: every recording of the held-out
#   recipes, labelled by the exact check) -> eval model-checking on the real and on the synthetic
#   test traces -> the page's section (pipelines/captaincook_table1.py). `make ... table1-page`
#   runs only this chain and puts its section into the existing page.
# SMALL=1: four recipes, 8 training recordings, 2 epochs, one seed (used by the tests); its page
# is $(OUT)/captaincook4d.md, the full run's docs/results/captaincook4d.md.
# Cost: one run per loss and size, seed 0, one λ (exact 1, tleaf 0.002), --epochs 150 --patience
# 20, one at a time under nice with OMP_NUM_THREADS=1 on 2 cores the other of which ran another
# training job (s, wall):
#     recordings    10    20    40    80   213   sum
#     none          10    11    20    32    77   151
#     exact          7    15    24    63   165   274
#     tleaf         14    88   231   192   349   873
# (tleaf's epochs cost 0.1 to 14 s: each new rule set of the predicted steps is compiled and
# embedded by q once.) The full curve, λ among two values and 0 for each logic loss, the λ-0
# run the none run: per seed 151 + 2 x 274 + 2 x 873 = 2,445 s (the dearest cell as the pipeline
# runs it, tleaf at 213 with --lambdas '0.002 0.02': 626 s), 5 seeds 12,200 s of runs, on
# 2 cores free for it (-j2) about 1.7 h, q and the evaluations a few minutes more; the Table I
# chain (T1_MINUTES per q_e and q_m) about 30 minutes more: 2 to 2.5 h in all. The epochs are
# not cut: at 213 recordings the reference still improves at epoch 150 (val action (step node)
# accuracy 60.7 %; stopped at 100 epochs 59.3 %, at 80 with patience 15 57.5 %), and at 40 its
# val accuracy stays flat for the first ~30 epochs (patience 10 stops it at 17.1 % against
# 22.2 %).
# make tracks files, not settings: give a new OUT when changing a setting.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
DATA ?= examples/captaincook4d
LOSSES ?= none exact tleaf
# λ per logic loss: each run chooses among these and 0 (no logic loss: the run of `none` at the
# same size and seed) the best on val. exact: at a fixed λ 1 it lost to none on test at 20 and at
# 213 recordings (7.5 against 9.3 %, 53.4 against 54.2 %), hence smaller ones; tleaf: around q's
# recommendation (its folder's recommended_lambda, about 0.002 on these rules)
LAMBDAS_exact ?= 0.1 1
LAMBDAS_tleaf ?= 0.002 0.02
NOISE ?= 2
DECODE_TOP_K ?= 5
BATCH := 16
# Table I on real traces: q's presets, their seeds, the recipes' train,val,test split (by recipe,
# drawn with T1_SPLIT_SEED), the length range of the synthetic traces (the recordings have 5 to 25
# steps), and a time limit per q_e and q_m (minutes: train-meta's --max-minutes, so the epochs
# that fit depend on the machine's load)
T1_PRESETS ?= best paper
T1_SEEDS ?= 0
T1_SPLIT ?= 0.6,0.2,0.2
T1_SPLIT_SEED ?= 0
T1_LENGTHS ?= --min-len 5 --max-len 25
# the synthetic traces: uniform (Table I's: satisfying and uniform violating words of T1_LENGTHS)
# or once-each (every step of the recipe exactly once, up to 3 steps it does not name: the shape
# of a recording); each in its own folder and page section
T1_TRACES ?= uniform
T1_DRAW_uniform = $(T1_LENGTHS) --hard-fraction 0
T1_DRAW_once-each = --once-each
T1_MINUTES ?= 10
OMP_NUM_THREADS ?= 1
export OMP_NUM_THREADS

ifeq ($(SMALL),1)
OUT ?= out/captaincook-small
RECIPES ?= coffee ramen tomatochutney zoodles
SIZES ?= 8
SEEDS ?= 0
ifeq ($(origin LAMBDAS_exact),file)
LAMBDAS_exact := 1
endif
ifeq ($(origin LAMBDAS_tleaf),file)
LAMBDAS_tleaf := 0.002
endif
TASK := --hidden 16 --epochs 2 --patience 2
PAGE := $(OUT)/captaincook4d.md
T1_K ?= 20
T1_EDGE := --epochs 1 --hidden 32 --out-dim 16
T1_META := --epochs 1 --hidden 32 --layers 2 --out-dim 16
Q_K := 4
Q_EDGE := --epochs 1 --hidden 32 --out-dim 16
Q_META := --epochs 1 --hidden 32 --layers 2 --out-dim 16
else
OUT ?= out/captaincook
RECIPES ?= $(basename $(notdir $(wildcard $(DATA)/task_graphs/*.json)))
SIZES ?= 10 20 40 80 213
SEEDS ?= 0 1 2 3 4
TASK := --epochs 150 --patience 20
PAGE := docs/results/captaincook4d.md
T1_K ?= 200
T1_EDGE := --epochs 3 --max-minutes $(T1_MINUTES)
T1_META := --epochs 10 --max-minutes $(T1_MINUTES)
Q_K := 40
Q_EDGE := --epochs 3
Q_META := --epochs 10 --max-minutes 3
endif

SPLITS := $(DATA)/data_splits/recordings_data_split_combined.json
# SIZES_<loss>, SEEDS_<loss>: the sizes and seeds a loss runs at (default SIZES, SEEDS; `none`
# needs every size and seed a logic loss has)
sizes_of = $(or $(SIZES_$(1)),$(SIZES))
seeds_of = $(or $(SEEDS_$(1)),$(SEEDS))
RUNS := $(foreach l,none $(filter-out none,$(LOSSES)),$(foreach n,$(call sizes_of,$(l)),\
	$(foreach s,$(call seeds_of,$(l)),$(OUT)/runs/$(l)-n$(n)-seed$(s)/metrics.json)))
ARGS_none = --logic-loss none
ARGS_exact = --logic-loss exact
ARGS_tleaf = --logic-loss tleaf --embedder $(OUT)/q/meta
DEPS_tleaf = $(OUT)/q/meta/metrics.json

.PHONY: all table1-page curve-page
all: $(PAGE)

$(OUT)/started:
	@mkdir -p $(@D)
	date +%s > $@

# the recipes' graphs (SMALL: a few of them; recordings of other recipes are left out)
$(OUT)/graphs/.copied: | $(OUT)/started
	@mkdir -p $(@D)
	cp $(foreach r,$(RECIPES),$(DATA)/task_graphs/$(r).json) $(@D)/
	touch $@
$(OUT)/edges.ltl: $(OUT)/graphs/.copied
	$(TLEAF) task-graph $(OUT)/graphs -o $@ -q
$(OUT)/recordings.parquet: | $(OUT)/started
	$(TLEAF) read-recordings $(DATA)/annotation_json --splits $(SPLITS) -o $@ -q
$(OUT)/checks/checks.parquet: $(OUT)/recordings.parquet $(OUT)/edges.ltl
	$(TLEAF) check-recordings $^ -o $(@D) -q
$(OUT)/activities.parquet $(OUT)/kb.ltl &: $(OUT)/recordings.parquet $(OUT)/graphs/.copied
	$(TLEAF) recording-activities $< $(OUT)/graphs -o $(OUT)/activities.parquet \
	    --kb-out $(OUT)/kb.ltl --noise $(NOISE) -q

# q for the tleaf loss: one for the whole knowledge base, trained on its rules one by one
# (compile-dfa --one-hot -> gen-traces -> train-edge -> train-meta; exit status 1 of gen-traces:
# some rule is short of Q_K traces, the others' are written and used)
$(OUT)/q/rules.parquet: $(OUT)/kb.ltl
	@mkdir -p $(@D)
	$(TLEAF) compile-dfa $< --one-hot -q -o $@
$(OUT)/q/traces.parquet: $(OUT)/q/rules.parquet
	$(TLEAF) gen-traces $< --one-hot --per-formula $(Q_K) --split 0.8,0.1,0.1 -q -o $@ \
	    || [ $$? -eq 1 ]
$(OUT)/q/edge/metrics.json: $(OUT)/q/rules.parquet
	$(TLEAF) train-edge $< -o $(@D) $(Q_EDGE) -q
$(OUT)/q/meta/metrics.json: $(OUT)/q/rules.parquet $(OUT)/q/traces.parquet \
    $(OUT)/q/edge/metrics.json
	$(TLEAF) train-meta $< $(OUT)/q/traces.parquet --edge $(OUT)/q/edge -o $(@D) $(Q_META) -q

# one run per loss, number of training recordings and seed; a logic loss chooses its λ on val
# among LAMBDAS_<loss> and 0, its λ-0 candidate the run without a logic loss of the same size and
# seed (--reference: λ 0 trains without the logic term, the same run, not trained again)
define RUN
$(OUT)/runs/$(1)-n$(2)-seed$(3)/metrics.json: $(OUT)/activities.parquet $(OUT)/kb.ltl \
    $(if $(filter none,$(1)),,$(OUT)/runs/none-n$(2)-seed$(3)/metrics.json) $(DEPS_$(1))
	$(TLEAF) train-task action-recognition $$< --kb $(OUT)/kb.ltl $(ARGS_$(1)) \
	    $(if $(filter none,$(1)),,--lambdas '$(LAMBDAS_$(1))' \
	    --reference $(OUT)/runs/none-n$(2)-seed$(3)) --train-videos $(2) --seed $(3) \
	    --batch-size $(BATCH) $(TASK) --decode constrained --decode-top-k $(DECODE_TOP_K) \
	    -o $$(@D) -q
endef
$(foreach l,none $(filter-out none,$(LOSSES)),$(foreach n,$(call sizes_of,$(l)),\
	$(foreach s,$(call seeds_of,$(l)),$(eval $(call RUN,$(l),$(n),$(s))))))

$(OUT)/eval/step_recognition.md: $(RUNS) $(OUT)/checks/checks.parquet
	$(TLEAF) eval step-recognition $(RUNS:/metrics.json=) --checks $(OUT)/checks/checks.parquet \
	    -o $(@D) -q
$(OUT)/curve/curve.md: $(RUNS)
	$(TLEAF) eval learning-curve $(RUNS:/metrics.json=) --measure pair -o $(@D) -q

# Table I on real traces: one q per preset and seed, trained on the synthetic traces of the train
# recipes, evaluated on the held-out recipes' real recordings and on their synthetic traces
T1 := $(OUT)/table1$(if $(filter once-each,$(T1_TRACES)),-once-each)
T1_REPORTS := $(foreach p,$(T1_PRESETS),$(foreach s,$(T1_SEEDS),\
	$(T1)/seed$(s)/eval-$(p)-real/report.json $(T1)/seed$(s)/eval-$(p)-synthetic/report.json))
$(T1)/recipes.ltl: $(OUT)/edges.ltl
	$(TLEAF) recipe-formulas $< -o $@ -q
$(T1)/dfas.parquet: $(T1)/recipes.ltl
	$(TLEAF) compile-dfa $< --one-hot -o $@ -q
$(T1)/traces.parquet: $(T1)/dfas.parquet
	$(TLEAF) gen-traces $< --one-hot --per-formula $(T1_K) $(T1_DRAW_$(T1_TRACES)) \
	    --split $(T1_SPLIT) --seed $(T1_SPLIT_SEED) -o $@ -q
$(T1)/recording_traces.parquet: $(OUT)/recordings.parquet $(OUT)/edges.ltl $(T1)/traces.parquet
	$(TLEAF) recording-traces $^ -o $@ -q
$(T1)/edge/metrics.json: $(T1)/dfas.parquet
	$(TLEAF) train-edge $< -o $(@D) $(T1_EDGE) --seed 0 -q
define T1_RUN
$(T1)/seed$(2)/meta-$(1)/metrics.json: $(T1)/traces.parquet $(T1)/edge/metrics.json
	$(TLEAF) train-meta $(T1)/dfas.parquet $$< --edge $(T1)/edge --preset $(1) $(T1_META) \
	    --seed $(2) -o $$(@D) -q
$(T1)/seed$(2)/eval-$(1)-real/report.json: $(T1)/recording_traces.parquet $(T1)/seed$(2)/meta-$(1)/metrics.json
	$(TLEAF) eval model-checking $(T1)/dfas.parquet $$< --embedder $(T1)/seed$(2)/meta-$(1) \
	    --label real --seed $(2) -o $$(@D) -q
$(T1)/seed$(2)/eval-$(1)-synthetic/report.json: $(T1)/traces.parquet $(T1)/seed$(2)/meta-$(1)/metrics.json
	$(TLEAF) eval model-checking $(T1)/dfas.parquet $$< --embedder $(T1)/seed$(2)/meta-$(1) \
	    --label synthetic --seed $(2) -o $$(@D) -q
endef
$(foreach p,$(T1_PRESETS),$(foreach s,$(T1_SEEDS),$(eval $(call T1_RUN,$(p),$(s)))))
T1_COMMAND = make -f pipelines/captaincook.mk$(if $(filter 1,$(SMALL)), SMALL=1) \
	T1_PRESETS="$(T1_PRESETS)" T1_SEEDS="$(T1_SEEDS)" T1_SPLIT=$(T1_SPLIT) T1_K=$(T1_K) \
	T1_MINUTES=$(T1_MINUTES)$(if $(filter once-each,$(T1_TRACES)), T1_TRACES=once-each)
$(T1)/section.md: $(T1_REPORTS) $(T1)/recording_traces.parquet
	$(PYTHON) pipelines/captaincook_table1.py $(T1) -o $@ --command '$(T1_COMMAND)'
# only this chain, its section put into the page as it is
table1-page: $(T1)/section.md
	$(PYTHON) pipelines/captaincook_table1.py $(T1) -o $(T1)/section.md \
	    --command '$(T1_COMMAND) table1-page' --page $(PAGE)

# the page up to its Table I sections: the step-recognition tables, the command, the rule check
# and the learning curve
PER_LOSS = $(strip $(foreach l,$(LOSSES),$(if $(SIZES_$(l)),SIZES_$(l)=\"$(SIZES_$(l))\") \
	$(if $(SEEDS_$(l)),SEEDS_$(l)=\"$(SEEDS_$(l))\")))
PER_LOSS_ARGS = $(if $(PER_LOSS), $(PER_LOSS))
define CURVE_PART
{ echo "# CaptainCook4D: real recordings, their recipes' rules, and step recognition"; \
  echo; \
  echo "Steps recognised along the real recordings (orders, durations, splits and rule"; \
  echo "violations real; features drawn per step: docs/procedures.md)."; \
  echo; \
  cat $(OUT)/eval/step_recognition.md; \
  echo; \
  echo "Command: \`make -f pipelines/captaincook.mk$(if $(filter 1,$(SMALL)), SMALL=1)" \
       "SIZES=\"$(SIZES)\" SEEDS=\"$(SEEDS)\" LOSSES=\"$(LOSSES)\"$(PER_LOSS_ARGS)" \
       "LAMBDAS_exact=\"$(LAMBDAS_exact)\"" \
       "LAMBDAS_tleaf=\"$(LAMBDAS_tleaf)\" NOISE=$(NOISE)$(1)\`;" \
       "wall time $$(( $$(stat -c %Y $(OUT)/eval/step_recognition.md $(OUT)/curve/curve.md \
       | sort -n | tail -1) - $$(cat $(OUT)/started) )) s on $$(getconf _NPROCESSORS_ONLN)" \
       "cores (from the first stage to the last evaluation, in $(OUT))."; \
  echo; \
  echo "## The rules as a detector of the recordings with errors (exact check)"; \
  echo; \
  sed -e 's/^## /### /' $(OUT)/checks/report.md; \
  echo; \
  echo "## Learning curve (step accuracy against training recordings)"; \
  echo; \
  sed -e '1{/^# /d;}' -e 's/^## /### /' $(OUT)/curve/curve.md; \
  echo; \
}
endef
CURVE_DEPS := $(OUT)/eval/step_recognition.md $(OUT)/curve/curve.md $(OUT)/checks/checks.parquet

$(PAGE): $(CURVE_DEPS) $(T1)/section.md
	@mkdir -p $(@D)
	{ $(call CURVE_PART); cat $(T1)/section.md; } > $@.tmp
	mv $@.tmp $@

# the curve alone (no Table I chain): the page's curve part rewritten, its Table I sections kept
curve-page: $(CURVE_DEPS)
	@mkdir -p $(dir $(PAGE))
	{ $(call CURVE_PART, curve-page); \
	  if [ -f $(PAGE) ]; then sed -n '/^<!-- captaincook-table1/,$$p' $(PAGE); fi; } > $(PAGE).tmp
	mv $(PAGE).tmp $(PAGE)
