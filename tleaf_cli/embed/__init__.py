"""The embedder q: graphs of DFAs, guards, traces and syntax trees; q's model, its loading and
embedding; the trainers of q_e and q_m.

Inference (model.py, load.py, model_folder.py, embedder.py, soft_traces.py and the encoders
they build) never imports a trainer (train_edge.py, train_meta.py, training.py, triplets.py,
edge_data.py) nor a dataset reader; the trainers import it. Depends on logic/ and data/, and on
torch / torch_geometric; nothing below it imports it (tests/test_layers.py).
"""
