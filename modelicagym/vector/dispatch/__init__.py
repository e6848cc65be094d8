"""What runs in the calling process only: the pool's commands to its parties, and its assembly.

The dispatcher (`dispatcher`) posts each command to the parties (`party`: a worker, through its
handle, `worker_handle`, or the calling process's own slice) and gathers their answers, waiting for
the workers in C (`native_collector`) and within a deadline (`deadline`); the workers' set
(`worker_set`) starts them and hands out the shared memory; `assembly` builds a pool from its layout
(`modelicagym.vector.layout`). Writing actions (`action_writer`), merging infos (`infos`), recovery
from a failed worker (`recovery`), partial batches (`partial_batches`), the caller's own slice's
watch (`caller_watch`) and timing (`timing_recorder`) are here too. Nothing here runs in a worker;
a worker is started from here (`worker_handle`)."""
