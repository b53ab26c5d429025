"""The shared last stages of every study: figures rendered, report written."""
