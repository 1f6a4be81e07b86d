# The paper's Fig. 5B (issue 7) on the SYNTHETIC Creative Cooking environment:
# gen-demos -> demos-kb -> compile-dfa --one-hot -> (gen-traces --one-hot -> train-edge ->
# train-meta: q, for the tleaf variant) -> train-task cooking (variants x seeds) -> eval cooking.
# Re-runs only what changed; `make -j` runs the GAIL runs in parallel.
#   make -f pipelines/cooking.mk [TLEAF=tleaf] [SMALL=1] [SEEDS="0 1"] [LOSSES="none tleaf"]
# SMALL=1: the whole chain with a tiny budget and 2 seeds in a minute or two (used by the tests).
TLEAF ?= tleaf
JOBS ?= 2
SMALL ?= 0
LOSSES ?= none tleaf exact checker

ifeq ($(SMALL),1)
OUT ?= out/cooking-small
SEEDS ?= 0 1
DEMOS := --episodes 1 --seed 1
K := 2
EDGE := --epochs 1 --hidden 32 --out-dim 16
META := --epochs 1 --hidden 32 --layers 2 --out-dim 16
TASK := --steps 512 --envs 2 --rollout 64 --eval-every 256 --eval-episodes 2
else
OUT ?= out/cooking
SEEDS ?= 0 1 2
DEMOS := --episodes 4 --seed 0
K := 10
EDGE := --epochs 3
META := --epochs 10 --max-minutes 3
TASK := --steps 40000 --eval-every 2048 --eval-episodes 8
endif

RUNS := $(foreach l,$(LOSSES),$(foreach s,$(SEEDS),$(OUT)/runs/$(l)-seed$(s)/metrics.json))

.PHONY: all clean
all: $(OUT)/report/report.md

# expert demonstrations; their ingredient sets are the episodes GAIL trains and is evaluated on
$(OUT)/demos.parquet:
	@mkdir -p $(@D)
	$(TLEAF) gen-demos -o $@ $(DEMOS) -q

# q's training formulas: every rule of those ingredient sets' knowledge bases, one by one
$(OUT)/kb.ltl: $(OUT)/demos.parquet
	$(TLEAF) demos-kb $< -o $@ -q
$(OUT)/rules.parquet: $(OUT)/kb.ltl
	$(TLEAF) compile-dfa $< --one-hot --jobs $(JOBS) -q -o $@
$(OUT)/traces.parquet: $(OUT)/rules.parquet
	$(TLEAF) gen-traces $< --one-hot --per-formula $(K) --split 0.8,0.1,0.1 --jobs $(JOBS) -q \
	    -o $@ || [ $$? -eq 1 ]
$(OUT)/edge/metrics.json: $(OUT)/rules.parquet
	$(TLEAF) train-edge $< -o $(@D) $(EDGE) -q
$(OUT)/meta/metrics.json: $(OUT)/rules.parquet $(OUT)/traces.parquet $(OUT)/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/rules.parquet $(OUT)/traces.parquet --edge $(OUT)/edge \
	    -o $(@D) $(META) -q

# one GAIL run per variant and seed; only tleaf needs q
define RUN
$(OUT)/runs/$(1)-seed$(2)/metrics.json: $(OUT)/demos.parquet \
    $(if $(filter tleaf,$(1)),$(OUT)/meta/metrics.json)
	$(TLEAF) train-task cooking $(OUT)/demos.parquet $(if $(filter tleaf,$(1)),--embedder $(OUT)/meta) \
	    --logic-loss $(1) --seed $(2) $(TASK) -o $$(@D) -q
endef
$(foreach l,$(LOSSES),$(foreach s,$(SEEDS),$(eval $(call RUN,$(l),$(s)))))

$(OUT)/report/report.md: $(RUNS)
	$(TLEAF) eval cooking $(dir $^) -o $(@D) -q

.SECONDARY:
clean:
	rm -rf $(OUT)
