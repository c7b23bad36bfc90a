"""The command line: typer commands and their plumbing."""
