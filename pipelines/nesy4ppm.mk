# NeSy4PPM's protocol (Oukharijane, Donadello, Maggi; github JamilaOUKHARIJANE/NeSy4PPM, package
# nesy4ppm 0.1) on its REAL data: Helpdesk with concept drift. The model learns from
# helpdesk_train.xes.gz (3,664 cases) and predicts the rest of each case of helpdesk_test.xes.gz
# (820 cases), a drifted process: every test case keeps the MP-Declare knowledge
# BK_helpdesk.decl (Closed is done by Value 3, right after Resolve ticket), 0.5 % of the
# training cases do. Suffixes of activity AND resource, from prefixes of 1-4 events (the rows
# whose true suffix is not empty: 2,953), by beam search of width 3, four ways as NeSy4PPM's
# modes: argmax (greedy), beam, beam with the knowledge a hard filter (rules) and beam with
# the knowledge a soft, contextualised score (beam_soft, eval --rule-weight). Metrics: DL and
# Jaccard similarity of the predicted activities and resources, compliance (the share of
# prefix + suffix keeping the knowledge), milliseconds per row.
#   read-log (train: val and a test split carved from it, for early stopping; test: all test)
#   -> per model and seed: train-task next-activity --attributes org:resource (the model reads
#      the resource and predicts the next one given the next activity; no logic loss: the
#      knowledge is about the drifted process, which training never shows)
#   -> eval next-activity on the drift test set, per rule weight in WEIGHTS
#   -> the report ($(OUT)/nesy4ppm.md, pipelines/nesy4ppm_report.py).
#   make -f pipelines/nesy4ppm.mk DATA=PATH [OUT=out/nesy4ppm] [SEEDS="0 1 2 3 4"]
#       [MODELS="transformer lstm"] [WEIGHTS="1 5 20"] [-j2]
# DATA: a folder with NeSy4PPM's helpdesk_train.xes.gz, helpdesk_test.xes.gz and
# BK_helpdesk.decl, from its repository's docs/source/data/input/ (commit de8bd5c5; the
# repository has no licence file, so tleaf does not ship them: docs/results/suffix_knowledge.md
# says how to download them).
# The weight μ: no data shows the drifted process before the test (the training cases break
# the knowledge 99.5 % of the time), so it cannot be chosen on validation; NeSy4PPM fixes its
# own weight (0.9) likewise. WEIGHTS are all reported; the page says which one is the headline
# and how it was set.
# Models: the Transformer of ProcessTransformer's size (NeSy4PPM's: one block of width 36,
# 4 heads), Tax et al.'s LSTM, and (MODELS=transformer-grid) the Transformer whose width and
# depth are chosen on validation (--grid). Cost (one core each, OMP_NUM_THREADS=1): about 20 s per
# training, 1-2 minutes per evaluation (the hard filter's search most of it).
TLEAF ?= tleaf
PYTHON ?= python
SEEDS ?= 0 1 2 3 4
MODELS ?= transformer lstm
WEIGHTS ?= 1 5 20
BEAM ?= 3
PREFIXES ?= 1-4
MAX_SUFFIX ?= 15
OUT ?= out/nesy4ppm
export OMP_NUM_THREADS ?= 1

ifndef DATA
$(error DATA=PATH is required: NeSy4PPM's helpdesk_train.xes.gz, helpdesk_test.xes.gz, BK_helpdesk.decl)
endif
TRAIN_LOG := $(DATA)/helpdesk_train.xes.gz
TEST_LOG := $(DATA)/helpdesk_test.xes.gz
BK := $(DATA)/BK_helpdesk.decl
needed := $(TRAIN_LOG) $(TEST_LOG) $(BK)
source := docs/results/suffix_knowledge.md says where from
include $(dir $(lastword $(MAKEFILE_LIST)))inputs.mk

MODEL_transformer := --model transformer --hidden 36 --layers 1 --heads 4
MODEL_lstm := --model lstm --hidden 100 --layers 2
# the Transformer's width and depth chosen on validation (the training log's own val split)
MODEL_transformer-grid := --model transformer --heads 4 --grid "hidden=36,64 layers=1,2"
RUNS := $(foreach m,$(MODELS),$(foreach s,$(SEEDS),$(OUT)/$(m)/seed$(s)))
EVALS := $(foreach r,$(RUNS),$(foreach w,$(WEIGHTS),$(r)/eval-w$(w)/metrics.json))

.PHONY: all evals clean
all: $(OUT)/nesy4ppm.md
evals: $(EVALS)

$(OUT)/train.parquet: $(TRAIN_LOG)
	@mkdir -p $(@D)
	$(TLEAF) read-log $< --attributes org:resource --split 0.8,0.1,0.1 --seed 0 -o $@ -q
$(OUT)/test.parquet: $(TEST_LOG)
	@mkdir -p $(@D)
	$(TLEAF) read-log $< --attributes org:resource --split 0,0,1 -o $@ -q

define run_rules
$(OUT)/$(1)/seed$(2)/metrics.json: $(OUT)/train.parquet
	$(TLEAF) train-task next-activity $$< $(MODEL_$(1)) --attributes org:resource \
	    --seed $(2) -o $$(@D) -q
$(foreach w,$(WEIGHTS),$(OUT)/$(1)/seed$(2)/eval-w$(w)/metrics.json): \
$(OUT)/$(1)/seed$(2)/eval-w%/metrics.json: $(OUT)/$(1)/seed$(2)/metrics.json $(OUT)/test.parquet
	$(TLEAF) eval next-activity $(OUT)/$(1)/seed$(2) $(OUT)/test.parquet --rules $(BK) \
	    --prefix-lengths $(PREFIXES) --beam-width $(BEAM) --min-suffix 1 \
	    --max-suffix $(MAX_SUFFIX) --rule-weight $$* -o $$(@D) -q
endef
$(foreach m,$(MODELS),$(foreach s,$(SEEDS),$(eval $(call run_rules,$(m),$(s)))))

$(OUT)/nesy4ppm.md: $(EVALS) pipelines/nesy4ppm_report.py
	$(PYTHON) pipelines/nesy4ppm_report.py $(OUT) --models $(MODELS) --seeds $(SEEDS) \
	    --weights $(WEIGHTS) -o $@

clean:
	rm -rf $(OUT)
