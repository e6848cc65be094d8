"""The pool starts wherever users run Python: a script with or without a main guard, a script
piped on stdin, ``python -c``; with envs defined in the script itself."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from extras import imported

pytestmark = pytest.mark.timeout(180)

SCRIPT = textwrap.dedent(
    """
    import gymnasium as gym
    import numpy as np

    import modelicagym
    from modelicagym.vector import PoolVectorEnv


    class Doubler(gym.Env):
        observation_space = gym.spaces.Box(-1e9, 1e9, (1,), np.float64)
        action_space = gym.spaces.Discrete(2)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            self.value = 1.0
            return np.array([self.value]), {}

        def step(self, action):
            self.value *= 2
            return np.array([self.value]), float(action), False, False, {}


    {guard}
        envs = modelicagym.make_vec("cartpole", n=2, start_method="{start_method}")
        envs.reset(seed=0)
        print("cartpole", envs.step(np.array([0, 1]))[1].tolist())
        envs.close()
        pool = PoolVectorEnv([lambda: Doubler()] * 2, num_workers=2, start_method="{start_method}")
        pool.reset(seed=0)
        print("doubler", pool.step(np.array([0, 1]))[0].ravel().tolist())
        pool.close()
    """
)
EXPECTED = "cartpole [1.0, 1.0]\ndoubler [2.0, 2.0]\n"


def script(guarded: bool, start_method: str) -> str:
    guard = 'if __name__ == "__main__":' if guarded else "if True:"
    return SCRIPT.replace("{guard}", guard).replace("{start_method}", start_method)


@pytest.mark.parametrize("start_method", ["forkserver", "spawn"])
@pytest.mark.parametrize("how", ["file with guard", "file without guard", "stdin", "-c"])
def test_the_pool_runs_however_the_script_is_run(tmp_path: Path, how: str, start_method: str) -> None:
    code = script(guarded=how == "file with guard", start_method=start_method)
    path = tmp_path / "user_script.py"
    path.write_text(code)
    command = {
        "file with guard": ([sys.executable, str(path)], None),
        "file without guard": ([sys.executable, str(path)], None),
        "stdin": ([sys.executable, "-"], code),
        "-c": ([sys.executable, "-c", code], None),
    }[how]
    result = subprocess.run(command[0], input=command[1], capture_output=True, text=True, timeout=150, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout == EXPECTED


def test_the_pool_runs_in_a_jupyter_notebook(tmp_path: Path) -> None:
    nbformat, nbclient = imported("nbformat"), imported("nbclient")
    cell = SCRIPT.replace("{guard}", "if True:").replace("{start_method}", "forkserver")
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(cell)])
    nbclient.NotebookClient(notebook, timeout=150, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = notebook.cells[0].outputs
    assert "".join(o.get("text", "") for o in outputs if o.output_type == "stream") == EXPECTED, outputs
