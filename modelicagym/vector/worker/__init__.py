"""What runs in a worker process only: its main loop (`worker_process`), started by the parent's
`~modelicagym.vector.parent.worker_handle`, stepping its slice (`modelicagym.vector.slice`) on command."""
