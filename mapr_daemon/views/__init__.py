"""The catalog as people read it: text tables, JSON and CSV, plots and the HTML report."""
