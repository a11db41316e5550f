"""The experiment application: whole experiments run and resumed, the study, re-evaluations."""
