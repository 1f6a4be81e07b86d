"""Knowledge: rules as `.ltl` files, where they come from and the rule sets they give sequences.

`base` reads, writes, extracts and mines knowledge bases of (action, ingredient) rules
(docs/knowledge.md); `rule_sets` turns a knowledge base into each sequence's `RuleSet`;
`task_graphs` reads a recipe's task graph as precedence rules. For event logs, `declare` mines
Declare constraints from cases, `log_knowledge` writes them (and the peers' formulas, converted
by `peer_formulas`) as files; `mining_arguments` checks what the miners are given. Used by the
tasks, the losses and the commands; depends on logic/ and data/, never on torch.
"""
