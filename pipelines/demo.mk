# The README's main job: compile the bundled example rules (both alphabets) and show one, then run
# the whole model-checking chain (paper Table I) on a small synthetic set and print its table.
#   make -f pipelines/demo.mk [TLEAF=tleaf] [OUT=out/demo]
TLEAF ?= tleaf
OUT ?= out/demo
RULES := examples/cooking_rules.ltl

.PHONY: all example model-checking clean
all: example model-checking

example: $(OUT)/dfas.parquet $(OUT)/dfas-onehot.parquet
	$(TLEAF) inspect $(OUT)/dfas.parquet
	$(TLEAF) inspect $(OUT)/dfas-onehot.parquet --id rinse_before_cook
	@echo "graph files (GraphML, DOT) in $(OUT)/graphs/"

# SMALL=1: synthetic formulas -> DFAs -> traces -> q_e -> q_m and the syntax baseline -> the
# model-checking evaluation -> one table (tiny models: the chain, not the paper's numbers).
model-checking:
	$(MAKE) -f pipelines/model_checking.mk TLEAF=$(TLEAF) SMALL=1 OUT=$(OUT)/model-checking
	@cat $(OUT)/model-checking/results.md
	@echo "(SMALL=1: 40 synthetic formulas and tiny models check that the chain runs; these numbers"
	@echo " mean nothing. The full run and its table: docs/results/model_checking.md)"

$(OUT)/dfas.parquet: $(RULES)
	$(TLEAF) compile-dfa $< -o $@ --graphs $(OUT)/graphs

$(OUT)/dfas-onehot.parquet: $(RULES)
	$(TLEAF) compile-dfa $< -o $@ --one-hot

clean:
	rm -rf $(OUT)
