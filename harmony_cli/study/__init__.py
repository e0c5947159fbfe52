"""Studies: a base scenario over randomised scenes (and grid axes), run resumably on a process pool or Ray, its
results one Parquet row per run and a report with success rates and their intervals."""
