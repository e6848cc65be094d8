"""Stepping envs against the shared buffers: runs in whichever process owns a slice of envs.

A worker process steps its slice; the calling process steps its own when it has one
(``caller_steps``). Creating the envs, stepping them in Python (`env_slice`) or in one C call
(`native_slice`, `slice_endings`), and checking that they agree on their spaces. Nothing here knows
of processes, pipes or signals."""
