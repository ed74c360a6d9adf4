"""The user interface of long runs: progress bars and log lines (never imported by core/ or solvers/)."""
