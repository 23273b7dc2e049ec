"""Files: mesh readers and writers, the on-disk cache."""
