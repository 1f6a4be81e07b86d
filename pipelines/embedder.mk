# q_e then q_m (train-meta's default, preset best) on one synthetic tier, and the syntax-tree baseline.
#   make -f pipelines/embedder.mk [TLEAF=tleaf] [DATA=out/data] [TIER=low] [SEED=0]
# Needs $(DATA)/$(TIER)/{dfas,traces}.parquet from pipelines/data.mk.
TLEAF ?= tleaf
DATA ?= out/data
TIER ?= low
SEED ?= 0
OUT ?= out/embed/$(TIER)
EDGE_EPOCHS ?= 5
META_EPOCHS ?= 30
META_MINUTES ?= 7

DFAS := $(DATA)/$(TIER)/dfas.parquet
TRACES := $(DATA)/$(TIER)/traces.parquet

.PHONY: all clean
all: $(OUT)/meta-dfa/metrics.json $(OUT)/meta-syntax/metrics.json

$(OUT)/edge/metrics.json: $(DFAS)
	$(TLEAF) train-edge $< -o $(@D) --epochs $(EDGE_EPOCHS) --seed $(SEED)

$(OUT)/meta-%/metrics.json: $(DFAS) $(TRACES) $(OUT)/edge/metrics.json
	$(TLEAF) train-meta $(DFAS) $(TRACES) --edge $(OUT)/edge -o $(@D) --embedder $* \
	    --epochs $(META_EPOCHS) --max-minutes $(META_MINUTES) --seed $(SEED)

clean:
	rm -rf $(OUT)
