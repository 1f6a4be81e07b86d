# The README's main job: compile the bundled example rules, both alphabets, then show them.
#   make -f pipelines/demo.mk [TLEAF=tleaf] [OUT=out/demo]
TLEAF ?= tleaf
OUT ?= out/demo
RULES := examples/cooking_rules.ltl

.PHONY: all clean
all: $(OUT)/dfas.parquet $(OUT)/dfas-onehot.parquet
	$(TLEAF) inspect $(OUT)/dfas.parquet
	$(TLEAF) inspect $(OUT)/dfas-onehot.parquet --id rinse_before_cook
	@echo "graph files (GraphML, DOT) in $(OUT)/graphs/"

$(OUT)/dfas.parquet: $(RULES)
	$(TLEAF) compile-dfa $< -o $@ --graphs $(OUT)/graphs

$(OUT)/dfas-onehot.parquet: $(RULES)
	$(TLEAF) compile-dfa $< -o $@ --one-hot

clean:
	rm -rf $(OUT)
