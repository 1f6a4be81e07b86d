# The paper's Table I both ways: each q preset (PRESETS) on each data protocol (PROTOCOLS), per
# tier and model seed; the MLP scored at its val-chosen epoch and at its best test epoch.
#   make -f pipelines/table1_protocols.mk [TLEAF=tleaf] [SMALL=1] [PRESETS="paper-code best"]
#        [PROTOCOLS="paper tleaf"] [TIERS="low moderate high"] [SEEDS="0 1 2"] [PAGE=docs/...]
# Protocols (SYNTHETIC data, one draw per protocol and tier, DATA_SEED):
#   paper   the authors' Table I data: gen-formulas / gen-traces --protocol paper
#           (data/paper_protocol.py), --paper-arcs $(PAPER_ARCS)
#   tleaf   tleaf's tiers: gen-formulas --tier t --pairs K, gen-traces --per-formula K (half hard
#           negatives), as pipelines/model_checking.mk draws them
# Presets: any train-meta --preset (paper-code: the authors' q; best: tleaf's). Each q_m trains
# for EPOCHS_<preset> epochs when set (paper-code's own 200 take hours on one core).
# Per cell: train-edge (one q_e per protocol and tier, seed 0), train-meta, eval model-checking
# (its report keeps every MLP epoch's test score beside the val-chosen one); then the report
# script writes $(OUT)/table1_protocols.md and, with PAGE=, that section of the page.
# SMALL=1: the whole grid on a tiny set in about a minute (tests).
# Ablation (`make ... ablation`): paper-code on the authors' data (the grid's paper cell, seed
# 0, is its base), one choice at a time changed toward best, per ABLATION_TIERS; each variant's
# data and train-meta options are in the ABL_ lines below; the report's second table.
TLEAF ?= tleaf
PYTHON ?= python
SMALL ?= 0
DATA_SEED ?= 0
PRESETS ?= paper-code best
PROTOCOLS ?= paper tleaf
# what one arc of the authors' searched automaton is (docs/embedder.md): guard, their code's
# reading, keeps 0.5 % of draws, which gen-formulas' draw limit (50 per formula + 1,000) cannot
# reach for more than a few formulas; letter keeps about 12 % of Low's draws
PAPER_ARCS ?= letter
# the MLP's input per preset: the authors' [z_φ ; z_w] for their q, tleaf's rich features for
# best (pipelines/model_checking.mk: its evidence block is a product an MLP on concat misses)
PAIR_FEATURES_paper-code ?= concat
PAIR_FEATURES_paper-text ?= concat
PAIR_FEATURES_best ?= rich
PRECISION ?= auto
DEVICE ?= cpu
PAGE ?=
export OMP_NUM_THREADS ?= 1
# each call's wall and CPU seconds appended to $(OUT)/times.tsv (the report's cost table)
TIMED ?= $(if $(wildcard /usr/bin/time),/usr/bin/time -a -o $(OUT)/times.tsv -f '%e\t%U\t%S\t%C')

ifeq ($(SMALL),1)
OUT ?= out/table1-protocols-small
TIERS ?= low
SEEDS ?= 0
N := 30
K := 6
EDGE := --epochs 1 --hidden 16 --out-dim 16
EPOCHS_paper-code ?= 2
EPOCHS_best ?= 2
SIZE := --widths 32,16 --hidden 16 --out-dim 16
SIZE_best := --hidden 16 --out-dim 16
else
OUT ?= out/table1-protocols
TIERS ?= low moderate high
SEEDS ?= 0 1 2
N ?= 1000
K := 20
EDGE := --epochs 3
SIZE :=
SIZE_best :=
endif
# each preset's train-meta options (EPOCHS_<preset> shortens its schedule)
meta_flags = --preset $(1) $(if $(EPOCHS_$(1)),--epochs $(EPOCHS_$(1))) \
	$(if $(filter best,$(1)),$(SIZE_best),$(if $(filter paper-code paper-text,$(1)),$(SIZE),$(SIZE_best)))

# the formula and trace options of each protocol
FORMULAS_paper = --protocol paper --paper-arcs $(PAPER_ARCS)
FORMULAS_tleaf = --pairs $(K)
TRACES_paper = --protocol paper --paper-arcs $(PAPER_ARCS)
TRACES_tleaf = --per-formula $(K)

# the run's variables as the report's command prints them
SETTINGS = N=$(N) TIERS="$(TIERS)" SEEDS="$(SEEDS)" PRESETS="$(PRESETS)" PROTOCOLS="$(PROTOCOLS)" \
	PAPER_ARCS=$(PAPER_ARCS) DATA_SEED=$(DATA_SEED)$(foreach e,$(PRESETS),$(if $(EPOCHS_$(e)), EPOCHS_$(e)=$(EPOCHS_$(e))))

CELLS := $(foreach p,$(PROTOCOLS),$(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,$(PRESETS),\
	$(OUT)/$(p)/$(t)/seed$(s)/eval-$(e)/report.json))))

.PHONY: all clean ablation
all: $(OUT)/table1_protocols.md

# the report: the grid's cells found, and the ablation's when it has been run
REPORT = $(PYTHON) pipelines/table1_protocols_report.py $(OUT) -o $(OUT)/table1_protocols.md \
	$(if $(PAGE),--page $(PAGE)) --settings '$(SETTINGS)' --protocols "$(PROTOCOLS)" \
	--presets "$(PRESETS)" --seeds "$(SEEDS)" \
	$(if $(wildcard $(OUT)/ablation),--ablation "$(VARIANTS)" --ablation-tiers "$(ABLATION_TIERS)" \
	--ablation-settings '$(ABL_SETTINGS)')
$(OUT)/table1_protocols.md: $(CELLS)
	$(REPORT)


define DATA
$(OUT)/$(1)/%/formulas.ltl:
	@mkdir -p $$(@D)
	$(TIMED) $(TLEAF) gen-formulas --tier $$* -n $(N) $(FORMULAS_$(1)) --seed $(DATA_SEED) -q -o $$@
$(OUT)/$(1)/%/dfas.parquet: $(OUT)/$(1)/%/formulas.ltl
	$(TIMED) $(TLEAF) compile-dfa $$< -q -o $$@
$(OUT)/$(1)/%/traces.parquet: $(OUT)/$(1)/%/dfas.parquet
	$(TIMED) $(TLEAF) gen-traces $$< $(TRACES_$(1)) --split 0.8,0.1,0.1 --seed $(DATA_SEED) -q -o $$@ \
	    $(if $(filter tiers-paper,$(1)),|| test -s $$@)
$(OUT)/$(1)/%/edge/metrics.json: $(OUT)/$(1)/%/dfas.parquet
	$(TIMED) $(TLEAF) train-edge $$< -o $$(@D) $(EDGE) --device $(DEVICE) --seed 0 -q
# kept (.PRECIOUS names a pattern rule's own target pattern), not every target made secondary:
# with .SECONDARY a finished report would hide seeds added later
.PRECIOUS: $(OUT)/$(1)/%/formulas.ltl $(OUT)/$(1)/%/dfas.parquet $(OUT)/$(1)/%/traces.parquet \
    $(OUT)/$(1)/%/edge/metrics.json
endef
$(foreach p,$(PROTOCOLS),$(eval $(call DATA,$(p))))

# the ablation: each variant's data (a protocol's folder and its traces file) and q options
VARIANTS ?= base trimmed positives negatives formulas directed readout sphere optimiser \
    distance
ABLATION_TIERS ?= $(TIERS)
ABL_DATA = $(or $(ABL_DATA_$(1)),paper)
ABL_TRACES = $(or $(ABL_TRACES_$(1)),traces)
ABL_TRACES_positives = traces-tleaf-positives
ABL_TRACES_negatives = traces-hard-negatives
ABL_DATA_formulas = tiers-paper
ABL_FLAGS_trimmed = --no-dead-state
ABL_FLAGS_directed = --no-directed
ABL_FLAGS_readout = --readout walk --walk-from initial --steps 24
ABL_FLAGS_sphere = --no-sphere
ABL_FLAGS_optimiser = --lr 0.001 --weight-decay 0 --schedule cosine
ABL_FLAGS_distance = --distance squared
# the data variants' traces, drawn for the paper protocol's formulas: tleaf's positives (uniform
# accepted words of 2-12 letters, each paired with a uniform rejected word of its length; a
# formula with fewer than K distinct pairs keeps those it has, listed by gen-traces), or the
# authors' positives with tleaf's half hard negatives; the formula variant: tleaf's tier formulas
# with the authors' traces (a formula their filters would have dropped, with no simple accepting
# path or no rejected word of a path's length, gets none: gen-traces lists them and exits 1)
FORMULAS_tiers-paper = $(FORMULAS_tleaf)
TRACES_tiers-paper = $(TRACES_paper)
$(OUT)/paper/%/traces-tleaf-positives.parquet: $(OUT)/paper/%/dfas.parquet
	$(TIMED) $(TLEAF) gen-traces $< --per-formula $(K) --hard-fraction 0 --split 0.8,0.1,0.1 \
	    --seed $(DATA_SEED) -q -o $@ || test -s $@
$(OUT)/paper/%/traces-hard-negatives.parquet: $(OUT)/paper/%/dfas.parquet
	$(TIMED) $(TLEAF) gen-traces $< $(TRACES_paper) --paper-hard 0.5 --split 0.8,0.1,0.1 \
	    --seed $(DATA_SEED) -q -o $@
$(if $(filter formulas,$(VARIANTS)),$(eval $(call DATA,tiers-paper)))
ABL_SETTINGS = N=$(N) ABLATION_TIERS="$(ABLATION_TIERS)" VARIANTS="$(VARIANTS)" \
	PAPER_ARCS=$(PAPER_ARCS) DATA_SEED=$(DATA_SEED)$(if $(EPOCHS_paper-code), EPOCHS_paper-code=$(EPOCHS_paper-code))
ABL_CELLS := $(foreach v,$(VARIANTS),$(foreach t,$(ABLATION_TIERS),$(OUT)/ablation/$(v)/$(t)/report.json))
ablation: $(ABL_CELLS)
	$(REPORT)

# base: the grid's paper-code cell on the authors' data, seed 0 (a copy of its report)
define ABLATE
$(OUT)/ablation/$(1)/$(2)/report.json: $(if $(filter base,$(1)),$(OUT)/paper/$(2)/seed0/eval-paper-code/report.json,$(OUT)/ablation/$(1)/$(2)/eval/report.json)
	@mkdir -p $$(@D)
	cp $$< $$@
$(OUT)/ablation/$(1)/$(2)/meta/metrics.json: $(OUT)/$(call ABL_DATA,$(1))/$(2)/$(call ABL_TRACES,$(1)).parquet $(OUT)/$(call ABL_DATA,$(1))/$(2)/edge/metrics.json
	$(TIMED) $(TLEAF) train-meta $(OUT)/$(call ABL_DATA,$(1))/$(2)/dfas.parquet $$< \
	    --edge $(OUT)/$(call ABL_DATA,$(1))/$(2)/edge -o $$(@D) $(call meta_flags,paper-code) \
	    $(ABL_FLAGS_$(1)) --device $(DEVICE) --seed 0 -q
$(OUT)/ablation/$(1)/$(2)/eval/report.json: $(OUT)/ablation/$(1)/$(2)/meta/metrics.json
	$(TIMED) $(TLEAF) eval model-checking $(OUT)/$(call ABL_DATA,$(1))/$(2)/dfas.parquet \
	    $(OUT)/$(call ABL_DATA,$(1))/$(2)/$(call ABL_TRACES,$(1)).parquet --embedder $$(<D) -o $$(@D) \
	    --label $(2) --seed 0 --pair-features $(PAIR_FEATURES_paper-code) --device $(DEVICE) \
	    --precision $(PRECISION) -q
endef
$(foreach v,$(VARIANTS),$(foreach t,$(ABLATION_TIERS),$(eval $(call ABLATE,$(v),$(t)))))

define RUN
$(OUT)/$(1)/$(2)/seed$(3)/meta-$(4)/metrics.json: $(OUT)/$(1)/$(2)/traces.parquet $(OUT)/$(1)/$(2)/edge/metrics.json
	$(TIMED) $(TLEAF) train-meta $(OUT)/$(1)/$(2)/dfas.parquet $$< --edge $(OUT)/$(1)/$(2)/edge \
	    -o $$(@D) $(call meta_flags,$(4)) --device $(DEVICE) --seed $(3) -q
$(OUT)/$(1)/$(2)/seed$(3)/eval-$(4)/report.json: $(OUT)/$(1)/$(2)/seed$(3)/meta-$(4)/metrics.json
	$(TIMED) $(TLEAF) eval model-checking $(OUT)/$(1)/$(2)/dfas.parquet $(OUT)/$(1)/$(2)/traces.parquet \
	    --embedder $$(<D) -o $$(@D) --label $(2) --seed $(3) \
	    --pair-features $(or $(PAIR_FEATURES_$(4)),rich) --device $(DEVICE) --precision $(PRECISION) -q
endef
$(foreach p,$(PROTOCOLS),$(foreach t,$(TIERS),$(foreach s,$(SEEDS),$(foreach e,$(PRESETS),\
	$(eval $(call RUN,$(p),$(t),$(s),$(e)))))))

clean:
	rm -rf $(OUT)
