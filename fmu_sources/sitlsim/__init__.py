"""ArduPilot SITL's physics for the JSON lock-step backend (``--model JSON``): a 6-DoF Iris quadcopter.

``lockstep.LockstepPhysics`` answers SITL's servo frames over UDP, one physics step per frame, so the
firmware's clock follows ours exactly; ``physics`` holds the kernel (compiled ``physics.c`` and its
bit-identical Python twin), ``iris`` the parameters, ``frames`` the packet codec.  docs/sitl_physics.md.
"""
