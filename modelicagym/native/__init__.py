"""Our own C library: the native step path and the pool's wait loop (see ``csrc/``)."""
