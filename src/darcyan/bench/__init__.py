"""The benchmark harness behind ``darcyan bench``."""
