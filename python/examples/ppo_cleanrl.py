#!/usr/bin/env python3
"""CleanRL-style PPO (single file, PyTorch) on Buridan's vector env.

CTDE with parameter sharing, as the dissertation's PPO-CTDE: one actor-critic
MLP (tanh, 64 x 64) acts for every agent from its local observation, with
the env's action mask applied to the logits (illegal moves get -1e8). Each
agent's reward is its own; an env's episode ends for all its agents at
once. ``buridan.VectorEnv`` steps ``num_envs`` envs in Rust and returns NumPy
views (no copies); the rollout buffers here are the only copies.

    pip install torch --index-url https://download.pytorch.org/whl/cpu
    python python/examples/ppo_cleanrl.py --map rm-2.1 --agents 4 --total-steps 300000

Prints per update the success rate and mean episode reward (summed over
agents: at most 6 for 4 agents) of the episodes finished in that update,
and at the end the mean over the last ten updates. Truncated episodes are
bootstrapped from the value of their last observation (``final_obs``).
"""

import argparse
import time

import numpy as np
import torch
import torch.nn as nn

from buridan import VectorEnv


def layer(i, o, std=np.sqrt(2), bias=0.0):
    lin = nn.Linear(i, o)
    nn.init.orthogonal_(lin.weight, std)
    nn.init.constant_(lin.bias, bias)
    return lin


class Agent(nn.Module):
    def __init__(self, obs_dim, hidden=64):
        super().__init__()
        self.critic = nn.Sequential(layer(obs_dim, hidden), nn.Tanh(), layer(hidden, hidden), nn.Tanh(),
                                    layer(hidden, 1, std=1.0))
        self.actor = nn.Sequential(layer(obs_dim, hidden), nn.Tanh(), layer(hidden, hidden), nn.Tanh(),
                                   layer(hidden, 5, std=0.01))

    def value(self, x):
        return self.critic(x).squeeze(-1)

    def act(self, x, mask, action=None):
        logits = self.actor(x).masked_fill(mask == 0, -1e8)
        dist = torch.distributions.Categorical(logits=logits)
        if action is None:
            action = dist.sample()
        return action, dist.log_prob(action), dist.entropy(), self.value(x)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--map", default="rm-2.1")
    ap.add_argument("--agents", type=int, default=4)
    ap.add_argument("--starts", default="random")
    ap.add_argument("--num-envs", type=int, default=32)
    ap.add_argument("--num-steps", type=int, default=64, help="rollout length per env")
    ap.add_argument("--total-steps", type=int, default=300_000, help="env steps (x agents = samples)")
    ap.add_argument("--lr", type=float, default=3e-4)
    ap.add_argument("--gamma", type=float, default=0.99)
    ap.add_argument("--gae-lambda", type=float, default=0.95)
    ap.add_argument("--epochs", type=int, default=4)
    ap.add_argument("--minibatches", type=int, default=4)
    ap.add_argument("--clip", type=float, default=0.2)
    ap.add_argument("--ent-coef", type=float, default=0.01)
    ap.add_argument("--vf-coef", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=1, help="torch and env threads")
    args = ap.parse_args()

    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    env = VectorEnv(args.map, args.agents, args.num_envs, starts=args.starts, seed=args.seed,
                    threads=args.threads)
    E, N, T = args.num_envs, args.agents, args.num_steps
    D = env.single_observation_space["observation"].shape[-1]
    agent = Agent(D)
    opt = torch.optim.Adam(agent.parameters(), lr=args.lr, eps=1e-5)

    obs_buf = torch.zeros(T, E, N, D)
    mask_buf = torch.zeros(T, E, N, 5, dtype=torch.uint8)
    act_buf = torch.zeros(T, E, N, dtype=torch.long)
    logp_buf = torch.zeros(T, E, N)
    rew_buf = torch.zeros(T, E, N)
    done_buf = torch.zeros(T, E)
    val_buf = torch.zeros(T, E, N)

    obs, _ = env.reset(seed=args.seed)
    updates = args.total_steps // (E * T)
    start, steps = time.time(), 0
    history = []
    for update in range(1, updates + 1):
        finished = []
        for t in range(T):
            # torch.from_numpy(np.array(view)): one copy into the rollout buffer.
            x = torch.from_numpy(np.array(obs["observation"]))
            m = torch.from_numpy(np.array(obs["action_mask"]))
            obs_buf[t], mask_buf[t] = x, m
            with torch.no_grad():
                a, logp, _, v = agent.act(x, m)
            act_buf[t], logp_buf[t], val_buf[t] = a, logp, v
            obs, rew, term, trunc, info = env.step(a.numpy().astype(np.uint8))
            rew_buf[t] = torch.from_numpy(np.array(rew))
            done = term | trunc
            done_buf[t] = torch.from_numpy(done.astype(np.float32))
            # Truncation: bootstrap from the last observation's value.
            if trunc.any():
                with torch.no_grad():
                    last = torch.from_numpy(np.array(info["final_obs"]["observation"]))
                    boot = agent.value(last)
                idx = torch.from_numpy(np.flatnonzero(trunc & ~term))
                rew_buf[t, idx] += args.gamma * boot[idx]
            finished += info.get("episodes", [])
            steps += E
        with torch.no_grad():
            next_v = agent.value(torch.from_numpy(np.array(obs["observation"])))
        adv = torch.zeros_like(rew_buf)
        gae = torch.zeros(E, N)
        for t in reversed(range(T)):
            nv = next_v if t == T - 1 else val_buf[t + 1]
            nonterm = 1.0 - done_buf[t].unsqueeze(-1)
            delta = rew_buf[t] + args.gamma * nv * nonterm - val_buf[t]
            gae = delta + args.gamma * args.gae_lambda * nonterm * gae
            adv[t] = gae
        ret = adv + val_buf

        b_obs, b_mask = obs_buf.reshape(-1, D), mask_buf.reshape(-1, 5)
        b_act, b_logp = act_buf.reshape(-1), logp_buf.reshape(-1)
        b_adv, b_ret = adv.reshape(-1), ret.reshape(-1)
        size = b_obs.shape[0]
        mb = size // args.minibatches
        for _ in range(args.epochs):
            perm = torch.randperm(size)
            for s in range(0, size, mb):
                i = perm[s:s + mb]
                _, logp, ent, v = agent.act(b_obs[i], b_mask[i], b_act[i])
                ratio = (logp - b_logp[i]).exp()
                a = b_adv[i]
                a = (a - a.mean()) / (a.std() + 1e-8)
                pg = torch.max(-a * ratio, -a * ratio.clamp(1 - args.clip, 1 + args.clip)).mean()
                vf = 0.5 * ((v - b_ret[i]) ** 2).mean()
                loss = pg + args.vf_coef * vf - args.ent_coef * ent.mean()
                opt.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), 0.5)
                opt.step()
        if finished:
            success = float(np.mean([e["success"] for e in finished]))
            reward = float(np.mean([e["reward"] for e in finished]))
            length = float(np.mean([e["length"] for e in finished]))
            history.append((steps, success, reward))
            print(f"update {update:4}/{updates}  env steps {steps:8}  episodes {len(finished):4}  "
                  f"success {success:5.2f}  reward {reward:6.2f}  length {length:5.1f}  "
                  f"{steps / (time.time() - start):7.0f} env-steps/s", flush=True)
    last = history[-10:]
    print(f"done: {steps} env steps in {time.time() - start:.0f} s; last {len(last)} updates: "
          f"success {np.mean([h[1] for h in last]):.2f}, reward {np.mean([h[2] for h in last]):.2f}")


if __name__ == "__main__":
    main()
