#!/usr/bin/env python3
"""A `learner train` checkpoint in PyTorch: ``model.safetensors`` is plain
safetensors, so ``safetensors.torch.load_file`` reads it and a few lines of
``torch.nn`` rebuild the policy; its logits match ``buridan.Policy``'s.

    pip install torch --index-url https://download.pytorch.org/whl/cpu
    pip install safetensors
    python python/examples/torch_policy.py fixtures/ppo-ctde-rm-2.1/checkpoint

Tensor names (``policy/src/net.rs``), per net ``k`` (one net for CTE and
CTDE, one per agent for DTE): ``net{k}.pi.{i}.weight|bias`` (hidden layer
``i``, weight ``[out, in]`` as ``torch.nn.Linear``), ``net{k}.vf.{i}.*``
(a separate value MLP), ``net{k}.lstm.*`` (PyTorch's LSTM layout),
``net{k}.logits.*``, ``net{k}.value.*``. This example handles MLP policies.
"""

import argparse
import json
from pathlib import Path

import numpy as np
import torch
import torch.nn as nn
from safetensors.torch import load_file

import buridan


class TorchPolicy(nn.Module):
    """The MLP actor of a Buridan checkpoint (tanh hidden layers, logits head)."""

    def __init__(self, tensors, spec, net=0):
        super().__init__()
        p = f"net{net}."
        dims = [spec["obs_dim"], *spec["hidden"]]
        self.hidden = nn.ModuleList(nn.Linear(i, o) for i, o in zip(dims, dims[1:]))
        self.logits = nn.Linear(dims[-1], spec.get("heads", 1) * spec.get("actions", 5))
        with torch.no_grad():
            for i, lin in enumerate(self.hidden):
                lin.weight.copy_(tensors[f"{p}pi.{i}.weight"])
                lin.bias.copy_(tensors[f"{p}pi.{i}.bias"])
            self.logits.weight.copy_(tensors[f"{p}logits.weight"])
            self.logits.bias.copy_(tensors[f"{p}logits.bias"])

    def forward(self, obs):
        h = obs
        for lin in self.hidden:
            h = torch.tanh(lin(h))
        return self.logits(h)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("checkpoint", type=Path, nargs="?",
                    default=Path("fixtures/ppo-ctde-rm-2.1/checkpoint"))
    ap.add_argument("--map", default="rm-2.1")
    args = ap.parse_args()

    spec = json.loads((args.checkpoint / "spec.json").read_text())
    if spec.get("lstm"):
        raise SystemExit("this example rebuilds MLP policies only")
    tensors = load_file(str(args.checkpoint / "model.safetensors"))
    print("tensors:", {k: tuple(v.shape) for k, v in tensors.items()})
    net = TorchPolicy(tensors, spec)

    ours = buridan.Policy.load(args.checkpoint)
    env = buridan.GridEnv(args.map, ours.agents, seed=7, **ours.env_kwargs())
    worst = 0.0
    for _ in range(50):
        obs, masks = env.obs(), env.masks()
        with torch.no_grad():
            torch_logits = net(torch.from_numpy(obs)).numpy()
        actions, _, logits = ours.act(obs, masks)
        worst = max(worst, float(np.abs(torch_logits - logits).max()))
        # Greedy under the mask, in PyTorch.
        torch_actions = np.where(masks == 1, torch_logits, -np.inf).argmax(axis=1)
        assert torch_actions.tolist() == actions[:, 0].tolist()
        env.step(actions[:, 0])
        if env.is_over:
            env.reset(env.episode + 1)
    print(f"PyTorch and buridan agree over 50 steps: max |logit difference| = {worst:.2e}")


if __name__ == "__main__":
    main()
