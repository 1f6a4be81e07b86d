"""Graphs built from DFAs, guards, traces and syntax trees; GNN encoders; triplet training.

Depends on logic/ and data/, and on torch / torch_geometric; nothing below it imports it.
"""
