"""Next-activity and suffix prediction on event logs: a Tax et al.-shaped LSTM, trained with
tleaf's logic losses, and suffixes searched under the rules (docs/event_logs.md)."""
