# The input check the pipelines on downloaded data share, included once they have set
#   needed     every input file the chosen runs read;
#   source     where a missing one comes from (a page of the docs);
#   PUBLISHED  the peers' figures (a folder or a file), where the pipeline reads them.
# Before anything runs (not for `make clean`), a missing input stops make, naming the first, how
# many more are missing and where they come from; one of the peers' figures also says that
# PUBLISHED= runs without them.
missing := $(filter-out $(wildcard $(needed)),$(needed))
ifneq ($(filter-out clean,$(or $(MAKECMDGOALS),all)),)
ifneq ($(missing),)
$(error missing input: $(firstword $(missing))$(if $(word 2,$(missing)), and $(words \
    $(wordlist 2,999,$(missing))) more) ($(source)$(if $(and $(PUBLISHED),$(filter \
    $(PUBLISHED)%,$(missing))),; PUBLISHED= runs without the peers' figures)))
endif
endif
