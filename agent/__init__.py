"""The streaming agent: rolling windows per loop, ownership of shards, reports on Zenoh."""
