"""Where each env of a pool is stepped, and why: the one place to read "why is my env in this process?".

The plan (`plan`: how many workers, which slice the calling process steps, and why it steps none),
the placement and every reason a layout is fixed (`placement`), the policy that moves envs between
the workers and the calling process (`policy`) with its cost model (`cost_model`), and the machine's
load they read (`machine_load`). Runs in the calling process; it imports no process's loop, only the
slices it places (`modelicagym.vector.slice`) and the shared memory (`modelicagym.vector.wire`)."""
