"""Command-line logic of subcommands, kept out of cli.py (which parses and dispatches)."""
