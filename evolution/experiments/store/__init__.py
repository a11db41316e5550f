"""The results store: the SQLite database, its schema upgrades, the results folder and snapshots."""
