"""Event logs: the schema and its validating reader/writer, the paper's datasets (2.1.6),
their summaries and figures."""
