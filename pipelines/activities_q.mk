# Shared part of the action-recognition pipelines (included by action_recognition.mk and
# learning_curve.mk, not run on its own): the synthetic videos, their knowledge base, and the
# embedder q the tleaf loss needs: gen-activities -> kb-extract -> compile-dfa --one-hot ->
# gen-traces --once-each -> train-edge -> train-meta. The including file sets TLEAF, JOBS, SMALL,
# OUT and DATA (gen-activities' flags) first; CLUSTER, when set, runs the parallel stages there.
# Why --once-each and q's options: docs/results/action_recognition.md.

# q_m: train-meta's default (preset best: monitors over each rule set's first 10 atoms, their
# naive-Bayes evidence, directed messages, runs readout, one radius, cosine schedule) with the
# options the action-recognition figures were measured with: rule sets' traces read up to 20
# letters (--max-length 20), --pull 0.02, monitor shares over all lengths together
# (--monitor-ranges 1), the learned part not on the sphere (--no-sphere), early stop after 5 epochs
Q := --max-length 20 --pull 0.02 --monitor-ranges 1 --no-sphere --patience 5
ifeq ($(SMALL),1)
K := 4
EDGE := --epochs 1 --hidden 32 --out-dim 16
META := --epochs 1 --hidden 32 --layers 2 --out-dim 16 $(Q)
else
K := 20
EDGE := --epochs 5
META := --epochs 15 $(Q)
endif

# synthetic videos and the knowledge base that generated them
# one command writes both (a grouped target: with `kb.ltl: activities.parquet ;` the KB, written
# first, looked older than the videos and a finished pipeline re-ran every stage)
$(OUT)/activities.parquet $(OUT)/kb.ltl &:
	@mkdir -p $(@D)
	$(TLEAF) gen-activities -o $(OUT)/activities.parquet --kb-out $(OUT)/kb.ltl $(DATA) --seed 0 -q

# q's training data: each video's rule set (labelled pairs), and every KB rule on its own so that
# q_e knows every atom a prediction can bring in (affordance rules name pairs no video shows)
$(OUT)/kb/dfas.parquet: $(OUT)/kb.ltl $(OUT)/activities.parquet
	$(TLEAF) kb-extract $^ -o $(@D) --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q
$(OUT)/rules.parquet: $(OUT)/kb.ltl
	$(TLEAF) compile-dfa $< --one-hot --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q -o $@
# traces shaped like the videos: each atom of a rule set once (+ a few "none" steps); exit
# status 1 = some rule set is short of K pairs (the empty set `true` has no violating trace, a
# two-atom set has two orders); the traces of the others are written and used
$(OUT)/traces.parquet: $(OUT)/kb/dfas.parquet
	$(TLEAF) gen-traces $< --once-each --per-formula $(K) --split 0.8,0.1,0.1 --jobs $(JOBS) $(if $(CLUSTER),--cluster $(CLUSTER)) -q \
	    -o $@ || [ $$? -eq 1 ]
$(OUT)/edge/metrics.json: $(OUT)/rules.parquet
	$(TLEAF) train-edge $< -o $(@D) $(EDGE) -q
$(OUT)/meta/metrics.json: $(OUT)/kb/dfas.parquet $(OUT)/traces.parquet $(OUT)/edge/metrics.json
	$(TLEAF) train-meta $(OUT)/kb/dfas.parquet $(OUT)/traces.parquet --edge $(OUT)/edge \
	    -o $(@D) $(META) -q
