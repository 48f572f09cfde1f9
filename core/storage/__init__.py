"""Files: the on-disk cache of G with its keyed checksums, atomic writes, the state folder."""
