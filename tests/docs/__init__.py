"""The documentation's examples and numbers, run as written."""
