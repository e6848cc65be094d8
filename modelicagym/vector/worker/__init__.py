"""What runs in a worker process only: its serve loop (`worker_process`), waiting for commands in C
where its envs step natively (`native_server`), started by the parent's
`~modelicagym.vector.dispatch.worker_handle`, stepping its slice (`modelicagym.vector.slice`) on command."""
