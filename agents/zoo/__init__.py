"""The zoo of shipped policies: shipping a run, the checksum manifest, ``pretrained/``."""
