"""Our own C library, as a leaf every layer may use: ``library`` builds and loads it (``csrc/``),
``abi`` mirrors its structs and constants and checks them at load. What each layer does with it
lives in that layer: the env's native step (`modelicagym.env.native_step`), the pool's native
slices (`modelicagym.vector.slice.native_slice`), the model-exchange solver loop
(`modelicagym.fmu.native_integrator`), the Q-learning agent (`modelicagym.agents.native_qlearning`)."""
