"""The hull model folder: its C sources and its variable table (variables.py)."""
