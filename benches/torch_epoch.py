"""The DS-STGAT of trainer/src/model.rs in PyTorch (CPU), trained on the tensors that
`cargo run --release -p pumptwin-trainer --example dump_tensors` writes, for the
burn-vs-PyTorch epoch-time comparison (benches/torch_vs_burn.sh runs both).

Same shapes, same data, same epochs, same loss (class-weighted CE of the network and
of the sensor head's two experts + lambda_ind * MSE of the indicator head), Adam with coupled L2 (burn's WeightDecay), the same cosine
learning-rate schedule, batches of 64, node dropout 0.2. Prints one JSON line with
the mean seconds per epoch of optimizer steps (what burn's history.json records).
"""
import json
import math
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

MASKED = -1e9


class Gat(nn.Module):
    def __init__(self, d_in, d):
        super().__init__()
        self.w = nn.Linear(d_in, d, bias=False)
        k = math.sqrt(6.0 / (d + 1.0))
        self.a_src = nn.Parameter(torch.empty(d).uniform_(-k, k))
        self.a_dst = nn.Parameter(torch.empty(d).uniform_(-k, k))
        self.bias = nn.Parameter(torch.zeros(d))

    def forward(self, h, adj, mask):  # [G,N,H], [G,N,N], [G,N]
        z = self.w(h)
        src = (z * self.a_src).sum(-1, keepdim=True)  # [G,N,1]
        dst = (z * self.a_dst).sum(-1).unsqueeze(1)  # [G,1,N]
        e = F.leaky_relu(src + dst, 0.2)
        edge = (adj > 0).float() * mask.unsqueeze(1)
        prior = adj.clamp_min(1e-30).log()
        alpha = (e + prior).masked_fill(edge < 0.5, MASKED).softmax(-1)
        return F.relu(alpha @ z + self.bias) * mask.unsqueeze(-1)


class Gru(nn.Module):
    def __init__(self, d_in, d):
        super().__init__()
        self.d = d
        self.input = nn.Linear(d_in, 3 * d)
        self.hidden_zr = nn.Linear(d, 2 * d, bias=False)
        self.hidden_n = nn.Linear(d, d, bias=False)

    def forward(self, u):  # [B,T,N,H]
        b, t, n, _ = u.shape
        d = self.d
        gx = self.input(u)
        s = u.new_zeros(b * n, d)
        out = []
        for k in range(t):
            g = gx[:, k].reshape(b * n, 3 * d)
            uzr = self.hidden_zr(s)
            z = torch.sigmoid(g[:, :d] + uzr[:, :d])
            r = torch.sigmoid(g[:, d:2 * d] + uzr[:, d:])
            cand = torch.tanh(g[:, 2 * d:] + self.hidden_n(r * s))
            s = s + z * (cand - s)
            out.append(s.reshape(b, n, d))
        return torch.stack(out, 1)


class DsStgat(nn.Module):
    def __init__(self, f, c, n, sensor_features, sensor_spectral, sensor_weight, kinematic_weight,
                 h=32, zc=16, ind=4):
        super().__init__()
        self.sensor_features = torch.tensor(sensor_features)
        self.spectral = sensor_spectral
        self.sensor_weight = sensor_weight
        self.kinematic_weight = kinematic_weight
        self.sensor = nn.Linear(n * sensor_spectral, c)
        self.kinematic = nn.Linear(n * (len(sensor_features) - sensor_spectral), c)
        self.embed = nn.Linear(f, h)
        self.gat = Gat(h, h)
        self.gru = Gru(h, h)
        self.score = nn.Linear(h, 1)
        self.compress = nn.Linear(h, zc)
        self.classifier = nn.Linear(zc, c)
        self.indicator = nn.Linear(zc, ind)

    def forward(self, x, adj, mask):
        b, t, n, _ = x.shape
        # Sensor head: the window mean of each present node's features, one weight row
        # per node (pumptwin_core::dsstgat::sensor_head_input), in two experts: the
        # spectral features of each slot and the kinematic ones (model::expert_inputs).
        xbar = x.index_select(3, self.sensor_features).mean(1) * mask.unsqueeze(2)
        sensor = self.sensor(xbar[:, :, :self.spectral].reshape(b, -1))
        kinematic = self.kinematic(xbar[:, :, self.spectral:].reshape(b, -1))
        h0 = F.relu(self.embed(x))
        d = h0.shape[-1]
        mask_bt = mask.unsqueeze(1).expand(b, t, n).reshape(b * t, n)
        u = self.gat(h0.reshape(b * t, n, d), adj.reshape(b * t, n, n), mask_bt).reshape(b, t, n, d)
        s = self.gru(u)
        score = self.score(s).reshape(b, t * n)
        # Readout at the source node 0 where present, every present node otherwise
        # (pumptwin_core::graph::NodeMask::readout, the burn model's readout_mask).
        source = mask[:, :1]
        only_source = torch.zeros_like(mask)
        only_source[:, :1] = source
        readout = only_source + mask * (1.0 - source)
        present = readout.unsqueeze(1).expand(b, t, n).reshape(b, t * n)
        beta = score.masked_fill(present < 0.5, MASKED).softmax(1)
        g = (beta.unsqueeze(1) @ s.reshape(b, t * n, d)).reshape(b, d)
        z = self.compress(g)
        network = self.classifier(z)
        logits = network + self.sensor_weight * sensor + self.kinematic_weight * kinematic
        return logits, network, sensor, kinematic, self.indicator(z)


def main():
    root = sys.argv[1]
    sh = json.load(open(f"{root}/shapes.json"))
    w, t, n, f = sh["windows"], sh["steps"], sh["nodes"], sh["features"]
    x = torch.from_numpy(np.fromfile(f"{root}/x.f32", dtype="<f4").reshape(w, t, n, f))
    adj = torch.from_numpy(np.fromfile(f"{root}/adj.f32", dtype="<f4").reshape(w, t, n, n))
    mask = torch.from_numpy(np.fromfile(f"{root}/mask.f32", dtype="<f4").reshape(w, n))
    ind = torch.from_numpy(np.fromfile(f"{root}/indicators.f32", dtype="<f4").reshape(w, -1))
    labels = torch.from_numpy(np.fromfile(f"{root}/labels.i64", dtype="<i8"))
    cw = torch.from_numpy(np.fromfile(f"{root}/class_weights.f32", dtype="<f4"))
    torch.manual_seed(42)
    model = DsStgat(f, sh["classes"], n, sh["sensor_features"], sh["sensor_spectral"],
                    sh["sensor_weight"], sh["kinematic_weight"], sh["hidden"], sh["compressed"], sh["indicators"])
    epochs = int(sys.argv[2]) if len(sys.argv) > 2 else sh["epochs"]
    bs = sh["batch_size"]
    lr0, lr1 = sh["learning_rate"], sh["learning_rate"] * sh["final_lr_fraction"]
    opt = torch.optim.Adam(model.parameters(), lr=lr0, weight_decay=2 * sh["lambda_reg"])
    steps_per_epoch = math.ceil(w / bs)
    total = steps_per_epoch * epochs
    gen = torch.Generator().manual_seed(42)
    step, times, accs = 0, [], []
    for _ in range(epochs):
        t0 = time.perf_counter()
        order = torch.randperm(w, generator=gen)
        correct = 0
        for k in range(0, w, bs):
            idx = order[k:k + bs]
            m = mask[idx] * (torch.rand(len(idx), n, generator=gen) >= sh["node_dropout"]).float()
            empty = m.sum(1) == 0
            m[empty] = mask[idx][empty]
            logits, network, sensor, kinematic, pi = model(x[idx], adj[idx], m)
            sw = cw[labels[idx]]
            sw = sw / sw.sum()

            def wce(lg):
                return -(F.log_softmax(lg, 1).gather(1, labels[idx].unsqueeze(1)).squeeze(1) * sw).sum()

            ce = wce(network) + wce(sensor) + wce(kinematic)
            loss = ce + sh["lambda_indicator"] * (pi - ind[idx]).pow(2).mean()
            correct += (logits.argmax(1) == labels[idx]).sum().item()
            p = step / max(total - 1, 1)
            for g in opt.param_groups:
                g["lr"] = lr1 + 0.5 * (lr0 - lr1) * (1 + math.cos(math.pi * p))
            opt.zero_grad()
            loss.backward()
            opt.step()
            step += 1
        times.append(time.perf_counter() - t0)
        accs.append(correct / w)
    print(json.dumps({
        "framework": f"torch {torch.__version__}", "threads": torch.get_num_threads(),
        "epochs": epochs, "windows": w,
        "seconds_per_epoch": sum(times) / len(times),
        "seconds_per_epoch_after_first": sum(times[1:]) / max(len(times) - 1, 1),
        "final_train_accuracy": accs[-1],
    }))


if __name__ == "__main__":
    main()
