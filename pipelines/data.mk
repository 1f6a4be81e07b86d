# Synthetic model-checking data for the paper's three tiers (docs/data.md).
#   make -f pipelines/data.mk [TIERS="low moderate high"] [N=1000] [K=20] [JOBS=2] [CLUSTER=tcp://HOST:8786] [SEED=0]
# Each tier: out/data/<tier>/formulas.ltl -> dfas.parquet -> traces.parquet (+ stats .txt).
TLEAF ?= tleaf
OUT ?= out/data
TIERS ?= low moderate high
N ?= 1000
K ?= 20
JOBS ?= 2
SEED ?= 0
SPLIT ?= 0.8,0.1,0.1

.PHONY: all clean
all: $(foreach t,$(TIERS),$(OUT)/$(t)/stats.txt)

$(OUT)/%/formulas.ltl:
	@mkdir -p $(@D)
	$(TLEAF) gen-formulas --tier $* -n $(N) --seed $(SEED) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -o $@

$(OUT)/%/dfas.parquet: $(OUT)/%/formulas.ltl
	$(TLEAF) compile-dfa $< --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -o $@

$(OUT)/%/traces.parquet: $(OUT)/%/dfas.parquet
	$(TLEAF) gen-traces $< --per-formula $(K) --split $(SPLIT) --seed $(SEED) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -o $@

$(OUT)/%/stats.txt: $(OUT)/%/dfas.parquet $(OUT)/%/traces.parquet
	{ head -2 $(OUT)/$*/formulas.ltl; $(TLEAF) inspect $(OUT)/$*/dfas.parquet --stats; \
	  $(TLEAF) inspect $(OUT)/$*/traces.parquet --stats; } > $@

.SECONDARY:
clean:
	rm -rf $(OUT)
