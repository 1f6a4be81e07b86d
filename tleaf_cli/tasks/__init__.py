"""Downstream experiments: model checking, action recognition, cooking imitation."""
