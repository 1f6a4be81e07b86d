"""Knowledge bases of (action, ingredient) rules and the rule sets they give sequences.

`base` reads, writes, extracts and mines knowledge bases (docs/knowledge.md); `rule_sets` turns a
knowledge base into each sequence's `RuleSet`. Shared by action recognition, cooking and the
losses; depends on logic/ and data/, never on torch.
"""
