"""A batch of envs stepped against the shared buffers: runs in whichever process owns a slice of envs.

A worker process steps its slice; the calling process steps its own when it has one
(``caller_steps``). Creating the envs, stepping them in Python (`env_slice`) or in one C call
(`native_slice`, `slice_endings`, `slice_edges`). Nothing here knows of processes, pipes or signals:
each process's wait loop around its slice is its own (`modelicagym.vector.worker.native_server`,
`modelicagym.vector.dispatch.native_collector`)."""
