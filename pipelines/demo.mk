# The README's main job (`bash run demo`, about two minutes on 2 cores), in three steps:
#   1. rules: the bundled cooking rules compiled to minimal DFAs; one shown as states and guarded
#      edges, its DOT and GraphML files written;
#   2. traces: satisfying and violating traces sampled for every rule, each checked by its DFA;
#   3. knowledge in a model: an action recogniser trained on SYNTHETIC videos without and with
#      the exact logic loss, its test videos decoded by argmax and under the rules (constrained
#      decoding) — accuracy and the share of videos that break a rule, in a table and a figure.
#   make -f pipelines/demo.mk [TLEAF=tleaf] [OUT=out/demo]
TLEAF ?= tleaf
OUT ?= out/demo
RULES := examples/cooking_rules.ltl
SEEDS := 0 1
# one torch thread per run, two runs at a time (make -j2)
OMP_NUM_THREADS ?= 1
export OMP_NUM_THREADS
AR := $(OUT)/action-recognition
RUNS := $(foreach l,none exact,$(foreach s,$(SEEDS),$(AR)/runs/lstm-$(l)-seed$(s)/metrics.json))

.PHONY: all rules traces model clean
all: rules traces model

rules: $(OUT)/dfas.parquet
	$(TLEAF) inspect $(OUT)/dfas.parquet
	$(TLEAF) inspect $(OUT)/dfas.parquet --id rinse_before_cook
	@echo "graph files of every rule (GraphML, DOT): $(OUT)/graphs/"

traces: $(OUT)/traces.parquet
	$(TLEAF) inspect $(OUT)/traces.parquet
	@echo "label: whether the trace satisfies its rule (each one checked by the rule's DFA)"

model: $(AR)/report/report.md
	@sed -n '/^| model | loss | runs | action acc |/,/^$$/p' $(AR)/report/report.md
	@sed -n '/^## Argmax against/,/^$$/p;/^| model | loss | runs | action acc argmax/,/^$$/p' \
	    $(AR)/report/report.md
	@echo "SYNTHETIC videos; figure: $(AR)/report/report.png; the full experiment:"
	@echo "docs/results/action_recognition.md"

$(OUT)/dfas.parquet: $(RULES)
	@mkdir -p $(@D)
	$(TLEAF) compile-dfa $< -o $@ --one-hot --graphs $(OUT)/graphs

$(OUT)/traces.parquet: $(OUT)/dfas.parquet
	$(TLEAF) gen-traces $< -o $@ --per-formula 4 --one-hot --seed 0

# one command writes both (a grouped target: with `kb.ltl: activities.parquet ;` the KB, written
# first, looked older than the videos and a finished pipeline re-ran every stage)
$(AR)/activities.parquet $(AR)/kb.ltl &:
	@mkdir -p $(@D)
	$(TLEAF) gen-activities -o $(AR)/activities.parquet --kb-out $(AR)/kb.ltl --seed 0 -q

# train-task's defaults: the LSTM, Adam lr 1e-3, up to 150 epochs, early stop after 20, test
# videos decoded by argmax and under the rules; the exact loss's λ 1
define RUN
$(AR)/runs/lstm-$(1)-seed$(2)/metrics.json: $(AR)/activities.parquet $(AR)/kb.ltl
	$(TLEAF) train-task action-recognition $(AR)/activities.parquet --kb $(AR)/kb.ltl \
	    --logic-loss $(1) --seed $(2) -o $$(@D) -q
endef
$(foreach l,none exact,$(foreach s,$(SEEDS),$(eval $(call RUN,$(l),$(s)))))

$(AR)/report/report.md: $(RUNS)
	$(TLEAF) eval action-recognition $(dir $^) -o $(@D) -q

clean:
	rm -rf $(OUT)
