"""Artifacts and their schemas, formula files, generators, and the dataset readers (event logs,
CaptainCook4D), which read into one shape, `cases.Cases`, through one interface,
`case_readers.CaseReader`. Depends on logic/, never on torch."""
