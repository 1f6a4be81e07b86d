"""Step recognition along real procedures: CaptainCook4D's recordings as an activities artifact
(`recording_activities`) for `train-task action-recognition`, and its evaluation with the soft
use of the recipes' rules, on the recordings that keep and that break them (`evaluate`)."""
