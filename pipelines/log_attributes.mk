# The attributes of the six logs of Rama-Maneiro et al.'s benchmark that their preprocessed CSVs
# drop, read from each log's XES (pipelines that read a log's attributes include this file):
#   EVENT_<log>, CASE_<log>   the event and case attributes read-log keeps (`reads`);
#   INPUTS_<log>, NUMERIC_<log>  those a model reads, categorical and numeric (`inputs`).
# what each log's XES keeps that its activities do not say, names apart by spaces (numbers that
# are codes, e.g. a resource id, are categorical: INPUTS; NUMERIC: numbers)
EVENT_Helpdesk := org:resource
INPUTS_Helpdesk := org:resource
EVENT_BPI_Challenge_2012_W_Complete := org:resource
CASE_BPI_Challenge_2012_W_Complete := AMOUNT_REQ
INPUTS_BPI_Challenge_2012_W_Complete := org:resource
NUMERIC_BPI_Challenge_2012_W_Complete := case:AMOUNT_REQ
EVENT_bpi_challenge_2013_incidents := org:resource org:group org:role impact product
INPUTS_bpi_challenge_2013_incidents := $(EVENT_bpi_challenge_2013_incidents)
EVENT_BPI_Challenge_2013_closed_problems := org:resource org:group
INPUTS_BPI_Challenge_2013_closed_problems := $(EVENT_BPI_Challenge_2013_closed_problems)
INPUTS_SEPSIS := org:group Diagnose InfectionSuspected SIRSCriteria2OrMore DiagnosticBlood \
    Hypotensie
NUMERIC_SEPSIS := CRP Leucocytes LacticAcid Age
EVENT_SEPSIS := $(INPUTS_SEPSIS) $(NUMERIC_SEPSIS)
EVENT_env_permit := org:resource org:group
CASE_env_permit := department channel responsible group
INPUTS_env_permit := $(EVENT_env_permit) $(addprefix case:,$(CASE_env_permit))
EVENT_mezini-closed := org:resource
INPUTS_mezini-closed := org:resource

space := $() $()
comma := ,
csv = $(subst $(space),$(comma),$(strip $(1)))
reads = $(if $(EVENT_$(1)),--attributes $(call csv,$(EVENT_$(1)))) \
    $(if $(CASE_$(1)),--case-attributes $(call csv,$(CASE_$(1))))
inputs = $(if $(INPUTS_$(1)),--inputs $(call csv,$(INPUTS_$(1)))) \
    $(if $(NUMERIC_$(1)),--numeric-inputs $(call csv,$(NUMERIC_$(1))))

# The log $(2)'s XES cases, its attributes kept (`reads`), under the benchmark CSV's case ids
# (pipelines/rm_case_ids.py: the benchmark's folds, case for case): $(1)/cases.parquet, from
# $(1)/xes.parquet and $(1)/csv.parquet (the including pipeline defines log_xes and log_csv).
define XES_CASES
$(1)/xes.parquet: $(call log_xes,$(2))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< $(call reads,$(2)) -o $$@ -q
$(1)/csv.parquet: $(call log_csv,$(2))
	@mkdir -p $$(@D)
	$(TLEAF) read-log $$< -o $$@ -q
$(1)/cases.parquet: $(1)/xes.parquet $(1)/csv.parquet pipelines/rm_case_ids.py
	$(PYTHON) pipelines/rm_case_ids.py $$(wordlist 1,2,$$^) -o $$@
endef
