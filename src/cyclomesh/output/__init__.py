"""Result-file writers: NetCDF, Parquet, CSV, JSON, TOML."""
