"""Bus traffic for the CLI: where records come from, which are kept, how they are written."""
