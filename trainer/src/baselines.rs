//! Baselines of the comparison table (paper §6.3.1), in burn, trained and evaluated
//! on exactly the windows, splits and noise of the DS-STGAT:
//!
//! | arch | input | what |
//! |---|---|---|
//! | `gcn-gru` | node features `[B, T, N, F]` | GCN on a fixed fully connected graph, GRU over steps, mean over nodes |
//! | `wdcnn` | raw `[B, N, 2048]` | Zhang et al. (2017): wide first kernel (64, stride 16), four small convs, BN |
//! | `cofusion-cnn` | raw `[B, N, 2048]` | one 1-D CNN branch per sensor, attention-weighted fusion of the branches |
//! | `tst` | raw `[B, N, 2048]` | time-series transformer: 32 patches of 64 samples × N channels, 2 encoder layers |
//!
//! Absent nodes: the raw-signal models see zeros for a missing channel (they have no
//! notion of a node; that is part of what the comparison shows), CoFusion-CNN's fusion
//! gives a missing branch no weight, GCN-GRU excludes it from the graph and the mean.
//!
//! ```text
//! GCN-GRU:  h⁰ = ReLU(W_in x),  Ā = D̃^−1/2 (M 1 1ᵀ M + I) D̃^−1/2 (M: present nodes),
//!           u = ReLU(Ā h⁰ W_g),  s = GRU(u) (eq. 7 form),  g = mean_present(s_T),  ŷ = W_o g
//! CoFusion: f_i = branch_i(x_i),  w = softmax_{i present}(vᵀ tanh(f_i)),  ŷ = W_o Σ w_i f_i
//! TST:      z_p = W_e [x_1,p ; … ; x_N,p] + e_p,  Z = Encoder(z),  ŷ = W_o mean_p Z_p
//! ```

use burn::module::{Module, Param};
use burn::nn::conv::{Conv1d, Conv1dConfig};
use burn::nn::pool::{MaxPool1d, MaxPool1dConfig};
use burn::nn::transformer::{
    TransformerEncoder, TransformerEncoderConfig, TransformerEncoderInput,
};
use burn::nn::{BatchNorm, BatchNormConfig, Linear, LinearConfig, PaddingConfig1d};
use burn::tensor::activation::{relu, softmax, tanh};
use burn::tensor::{Device, Distribution, Tensor};

use crate::model::{Gru, MASKED_LOGIT};
use pumptwin_data::featurize::WINDOW;

/// One conv → batch norm → ReLU → max-pool stage.
#[derive(Module, Debug)]
pub struct ConvStage {
    conv: Conv1d,
    norm: BatchNorm,
    pool: MaxPool1d,
}

impl ConvStage {
    fn new(
        c_in: usize,
        c_out: usize,
        kernel: usize,
        stride: usize,
        pad: usize,
        pool: usize,
        device: &Device,
    ) -> Self {
        Self {
            conv: Conv1dConfig::new(c_in, c_out, kernel)
                .with_stride(stride)
                .with_padding(PaddingConfig1d::Explicit(pad, pad))
                .init(device),
            norm: BatchNormConfig::new(c_out).init(device),
            pool: MaxPool1dConfig::new(pool).with_stride(pool).init(),
        }
    }

    /// `[B, C_in, L]` → `[B, C_out, L']`.
    fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        self.pool
            .forward(relu(self.norm.forward(self.conv.forward(x))))
    }
}

/// WDCNN (see the module docs).
#[derive(Module, Debug)]
pub struct Wdcnn {
    stages: Vec<ConvStage>,
    fc1: Linear,
    fc2: Linear,
}

impl Wdcnn {
    /// For `channels` sensors and `classes` classes.
    pub fn new(channels: usize, classes: usize, device: &Device) -> Self {
        // 2048 → conv(64, s16, p24) 128 → pool 64 → 32 → 16 → 8 → conv(3, p0) 6 → pool 3.
        let stages = vec![
            ConvStage::new(channels, 16, 64, 16, 24, 2, device),
            ConvStage::new(16, 32, 3, 1, 1, 2, device),
            ConvStage::new(32, 64, 3, 1, 1, 2, device),
            ConvStage::new(64, 64, 3, 1, 1, 2, device),
            ConvStage::new(64, 64, 3, 1, 0, 2, device),
        ];
        Self {
            stages,
            fc1: LinearConfig::new(64 * 3, 100).init(device),
            fc2: LinearConfig::new(100, classes).init(device),
        }
    }

    /// `raw`: `[B, N, 2048]` → logits `[B, C]` and the embedding `[B, 100]`.
    pub fn forward(&self, raw: Tensor<3>) -> (Tensor<2>, Tensor<2>) {
        let mut x = raw;
        for s in &self.stages {
            x = s.forward(x);
        }
        let [b, c, l] = x.dims();
        let h = relu(self.fc1.forward(x.reshape([b, c * l])));
        (self.fc2.forward(h.clone()), h)
    }
}

/// One CoFusion-CNN branch: three conv stages and a global mean.
#[derive(Module, Debug)]
pub struct Branch {
    stages: Vec<ConvStage>,
}

impl Branch {
    fn new(device: &Device) -> Self {
        // 2048 → conv(32, s8, p12) 256 → pool 64 → conv 3 → pool 16 → conv 3 → pool 8.
        Self {
            stages: vec![
                ConvStage::new(1, 16, 32, 8, 12, 4, device),
                ConvStage::new(16, 32, 3, 1, 1, 4, device),
                ConvStage::new(32, 64, 3, 1, 1, 2, device),
            ],
        }
    }

    /// `[B, 1, L]` → `[B, 64]`.
    fn forward(&self, x: Tensor<3>) -> Tensor<2> {
        let mut x = x;
        for s in &self.stages {
            x = s.forward(x);
        }
        let [b, c, _] = x.dims();
        x.mean_dim(2).reshape([b, c])
    }
}

/// CoFusion-CNN (see the module docs).
#[derive(Module, Debug)]
pub struct CoFusionCnn {
    branches: Vec<Branch>,
    fusion: Linear,
    head: Linear,
}

impl CoFusionCnn {
    /// One branch per sensor.
    pub fn new(channels: usize, classes: usize, device: &Device) -> Self {
        Self {
            branches: (0..channels).map(|_| Branch::new(device)).collect(),
            fusion: LinearConfig::new(64, 1).init(device),
            head: LinearConfig::new(64, classes).init(device),
        }
    }

    /// `raw`: `[B, N, 2048]`, `mask`: `[B, N]` → logits `[B, C]`, embedding `[B, 64]`.
    pub fn forward(&self, raw: Tensor<3>, mask: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let [b, n, l] = raw.dims();
        let feats: Vec<Tensor<2>> = self
            .branches
            .iter()
            .enumerate()
            .map(|(i, br)| br.forward(raw.clone().narrow(1, i, 1).reshape([b, 1, l])))
            .collect();
        let f = Tensor::stack::<3>(feats, 1); // [B, N, 64]
        let score = self.fusion.forward(tanh(f.clone())).reshape([b, n]); // [B, N]
        let w = softmax(score.mask_fill(mask.lower_elem(0.5), MASKED_LOGIT), 1); // [B, N]
        let fused = w.reshape([b, 1, n]).matmul(f).reshape([b, 64]); // [B, 64]
        (self.head.forward(fused.clone()), fused)
    }
}

/// Samples per TST patch.
pub const TST_PATCH: usize = 64;
/// TST model width.
pub const TST_D: usize = 32;

/// Time-series transformer (see the module docs).
#[derive(Module, Debug)]
pub struct Tst {
    embed: Linear,
    position: Param<Tensor<2>>,
    encoder: TransformerEncoder,
    head: Linear,
}

impl Tst {
    /// For `channels` sensors.
    pub fn new(channels: usize, classes: usize, device: &Device) -> Self {
        let patches = WINDOW / TST_PATCH;
        Self {
            embed: LinearConfig::new(channels * TST_PATCH, TST_D).init(device),
            position: Param::from_tensor(Tensor::random(
                [patches, TST_D],
                Distribution::Normal(0.0, 0.02),
                device,
            )),
            encoder: TransformerEncoderConfig::new(TST_D, 2 * TST_D, 4, 2)
                .with_dropout(0.1)
                .with_norm_first(true)
                .init(device),
            head: LinearConfig::new(TST_D, classes).init(device),
        }
    }

    /// `raw`: `[B, N, 2048]` → logits `[B, C]`, embedding `[B, D]`.
    pub fn forward(&self, raw: Tensor<3>) -> (Tensor<2>, Tensor<2>) {
        let [b, n, l] = raw.dims();
        let p = l / TST_PATCH;
        let tokens =
            raw.reshape([b, n, p, TST_PATCH])
                .swap_dims(1, 2)
                .reshape([b, p, n * TST_PATCH]); // [B, P, N·64]
        let z = self.embed.forward(tokens) + self.position.val().reshape([1, p, TST_D]);
        let z = self.encoder.forward(TransformerEncoderInput::new(z)); // [B, P, D]
        let g = z.mean_dim(1).reshape([b, TST_D]);
        (self.head.forward(g.clone()), g)
    }
}

/// GCN-GRU with a static graph (see the module docs).
#[derive(Module, Debug)]
pub struct GcnGru {
    embed: Linear,
    gcn: Linear,
    gru: Gru,
    head: Linear,
}

impl GcnGru {
    /// For `features` per node and `hidden` width.
    pub fn new(features: usize, hidden: usize, classes: usize, device: &Device) -> Self {
        Self {
            embed: LinearConfig::new(features, hidden).init(device),
            gcn: LinearConfig::new(hidden, hidden).init(device),
            gru: Gru::new(hidden, hidden, device),
            head: LinearConfig::new(hidden, classes).init(device),
        }
    }

    /// `x`: `[B, T, N, F]`, `mask`: `[B, N]` → logits `[B, C]`, embedding `[B, H]`.
    pub fn forward(&self, x: Tensor<4>, mask: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let [b, t, n, _] = x.dims();
        let device = x.device();
        // Ā = D^-1/2 (M M^T with unit diagonal) D^-1/2, the same for every step.
        let m = mask.clone().reshape([b, n, 1]);
        let eye = Tensor::<2>::eye(n, &device).reshape([1, n, n]);
        let off = m.clone().matmul(m.clone().swap_dims(1, 2)) * (eye.clone().neg() + 1.0);
        let a = off + eye; // [B, N, N]
        let inv_sqrt = a.clone().sum_dim(2).sqrt().recip(); // [B, N, 1]
        let a_hat = a * inv_sqrt.clone() * inv_sqrt.swap_dims(1, 2); // [B, N, N]
        let h0 = relu(self.embed.forward(x)); // [B, T, N, H]
        let d = h0.dims()[3];
        let a_bt = a_hat.reshape([b, 1, n, n]).repeat_dim(1, t); // [B, T, N, N]
        let u = relu(self.gcn.forward(a_bt.matmul(h0))) * m.clone().reshape([b, 1, n, 1]);
        let s = self.gru.forward(u); // [B, T, N, H]
        let last = s.narrow(1, t - 1, 1).reshape([b, n, d]) * m.clone(); // [B, N, H]
        let count = mask.sum_dim(1).clamp_min(1.0).reshape([b, 1]); // [B, 1]
        let g = last.sum_dim(1).reshape([b, d]) / count;
        (self.head.forward(g.clone()), g)
    }
}
