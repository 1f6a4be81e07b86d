"""Sequential action recognition with logic losses (the paper's Sec. VI, Fig. 4).

`models` holds the target model h (BiLSTM or TCN backbone, two heads), `train` the training run
behind `tleaf train-task action-recognition`, `evaluate` the report behind
`tleaf eval action-recognition`.
"""
