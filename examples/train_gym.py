"""Train a tiny policy on ``sdovon_mj/ObjectNav-v0`` with REINFORCE (torch), a few hundred steps: a starting point
for your own training code, not a baseline.

    python examples/train_gym.py --bundle out/demo/export/mjcf/sdovon --steps 300

The environment runs in training mode (``training=True``): its reward is the decrease of the geodesic distance to the
nearest goal view point, which is generator knowledge, there for training only (an evaluation with `sdovon-mj eval`
gives an agent no reward). The policy reads a coarse depth grid, GPS+compass and the goal index; it picks among
MOVE_FORWARD, TURN_LEFT and TURN_RIGHT, so an episode ends at the step limit and its return is the geodesic distance it
gained (m). STOP is left out: under the dense reward alone, stopping at once (return 0) beats an untrained walk, and a
policy learns just that; with STOP, add habitat-lab's success bonus (``info["success"]`` at the episode's end). Each
finished episode prints its steps and return.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gymnasium
import numpy as np

from sdovon_mj.suite.bundle import find_bundles

ENV = "sdovon_mj.suite.gym:sdovon_mj/ObjectNav-v0"
MOVES = ("MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT")
GRID = (3, 4)  # depth pooled to rows x columns


def features(obs: dict, goals: int) -> np.ndarray:
    """Return the policy's input: the depth pooled to `GRID` (normalised by 5 m), GPS (m / 5), compass as sine and
    cosine, and the goal category one-hot (`goals` categories)."""
    d = obs["depth"][..., 0]
    h, w = d.shape
    rows, cols = GRID
    pooled = d[: h - h % rows, : w - w % cols].reshape(rows, h // rows, cols, w // cols).mean(axis=(1, 3)).ravel() / 5.0
    c = float(obs["compass"][0])
    goal = np.zeros(goals, np.float32)
    goal[int(obs["objectgoal"][0])] = 1.0
    return np.concatenate([pooled, obs["gps"] / 5.0, [math.sin(c), math.cos(c)], goal]).astype(np.float32)


def main(argv: list[str] | None = None) -> int:
    """Train for ``--steps`` environment steps; print every episode's return."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bundle", required=True, help="an MJCF bundle (variant folder) or a dataset (its first variant)")
    p.add_argument("--steps", type=int, default=300, help="environment steps in all")
    p.add_argument("--max-steps", type=int, default=50, help="episode step limit")
    p.add_argument("--width", type=int, default=32)
    p.add_argument("--height", type=int, default=24)
    p.add_argument("--lr", type=float, default=0.01)
    p.add_argument("--gamma", type=float, default=0.99)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    import torch  # lazily: only training needs it

    bundles = find_bundles(Path(args.bundle))
    if not bundles:
        p.error(f"no MJCF bundle under {args.bundle}")
    print(f"bundle {bundles[0]}")
    env = gymnasium.make(ENV, bundle=str(bundles[0]), training=True, width=args.width, height=args.height,
                         max_steps=args.max_steps)
    names = env.unwrapped.action_names
    actions = [names.index(a) for a in MOVES]
    goals = int(env.observation_space["objectgoal"].high[0]) + 1
    torch.manual_seed(args.seed)
    n_in = GRID[0] * GRID[1] + 4 + goals
    policy = torch.nn.Sequential(torch.nn.Linear(n_in, 32), torch.nn.Tanh(), torch.nn.Linear(32, len(MOVES)))
    opt = torch.optim.Adam(policy.parameters(), lr=args.lr)

    obs, _ = env.reset(seed=args.seed)
    logps, rewards, returns, done_steps, episode = [], [], [], 0, 0
    while done_steps < args.steps:
        dist = torch.distributions.Categorical(logits=policy(torch.from_numpy(features(obs, goals))))
        k = dist.sample()
        obs, reward, terminated, truncated, _info = env.step(actions[int(k)])
        logps.append(dist.log_prob(k))
        rewards.append(float(reward))
        done_steps += 1
        if terminated or truncated or done_steps == args.steps:
            g, rtg = 0.0, []
            for r in reversed(rewards):
                g = r + args.gamma * g
                rtg.append(g)
            rtg_t = torch.tensor(rtg[::-1])
            loss = -(torch.stack(logps) * (rtg_t - rtg_t.mean())).sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
            episode += 1
            returns.append(sum(rewards))
            ended = "step limit" if truncated else ("stop" if terminated else "cut short by --steps")
            print(f"episode {episode}: {len(rewards)} steps, return {returns[-1]:+.3f} m ({ended})", flush=True)
            logps, rewards = [], []
            obs, _ = env.reset()
    half = max(len(returns) // 2, 1)
    print(f"{done_steps} steps, {episode} episodes; mean return first half {np.mean(returns[:half]):+.3f} m, "
          f"second half {np.mean(returns[half:] or returns):+.3f} m")
    env.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
