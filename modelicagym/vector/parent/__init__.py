"""What runs in the calling process only: the pool's parts behind its API.

Dispatching commands to the parties and gathering their answers, the worker processes' handles and
their set, building the pool, checking what the caller passes, merging infos, recovery from a
failed worker, and where each env is stepped (plan, placement, layout policy, cost balance).
Nothing here runs in a worker; a worker is started from here (`worker_handle`)."""
