"""The performance table (`python -m app bench`) and its rows."""
