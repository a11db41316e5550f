"""One shared world where robots are born and die: the PettingZoo population env.

Run from the repository root: ``python examples/online_world.py``.
"""

import revolve_env

# A few simulated seconds; the paper's online scenario runs a birth every 15 s for hours
# (raise SECONDS, and use evolution.run("scenario3") for the full online evolution).
SECONDS = 4.0
BIRTH_EVERY = 1.0   # seconds between births in this example
DEATH_AT = 2.5      # the first robot dies at this time (seconds)

env = revolve_env.population_env(
    max_births=10,          # size of possible_agents: robot_0 .. robot_9; ids are never reused
    insertion_time=0.5,     # seconds after birth before the fitness is sampled
    fitness_window=12.0,    # sliding window of f = v + 5 s, seconds
    engine="mujoco",        # or "pybullet" (the default)
)
observations, infos = env.reset(seed=1, options={"robots": [revolve_env.example("gecko")]})
dt = env.config.control_period  # seconds per env.step (the WorldConfig in use)
print(f"control period {dt:.4f} s; born at reset: {env.agents}")

newborns = [revolve_env.example(name) for name in ("spider", "snake", "bar_walker")]
steps_per_birth = round(BIRTH_EVERY / dt)
step = 0
while step * dt < SECONDS:
    step += 1
    # Births happen between steps: the newborn is placed at a free spot of the birth disc and
    # enters env.agents in the next step, which reports its first observation (PettingZoo's
    # convention: agents change only in step, so a policy over env.agents never misses one).
    if step % steps_per_birth == 0 and newborns:
        agent = env.add_robot(newborns.pop(0))
        print(f"t = {step * dt:.2f} s: born {agent}")
    # Deaths too: the robot leaves the world now; the next step reports it terminated and
    # takes it out of env.agents.
    if step == round(DEATH_AT / dt):
        env.remove_robot("robot_0")
        print(f"t = {step * dt:.2f} s: removed robot_0")
    # Brain-controlled robots need no actions: the compiled controller steps all their networks.
    observations, rewards, terminations, truncations, infos = env.step({})
    for agent, info in infos.items():
        if terminations[agent]:
            print(f"t = {step * dt:.2f} s: {agent} died ({info['death']}) "
                  f"at age {info['age']:.2f} s, fitness {info['fitness']:.3f} m")

print(f"after {env.time:.2f} s and {env.births} births, alive: {env.agents}")
for agent in env.agents:
    info = infos[agent]
    print(f"{agent}: age {info['age']:.2f} s, fitness {info['fitness']:.3f} m, "
          f"mature {info['is_mature']}")
env.close()
