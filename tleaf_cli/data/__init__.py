"""Artifacts and their schemas, formula files, generators. Depends on logic/, never on torch."""
