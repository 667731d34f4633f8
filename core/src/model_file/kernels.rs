//! The typed builders: a decoded file's layers as the int8 [`crate::quant`] kernels,
//! checked against the compile-time sizes asked for, by value or filled in place.

use crate::error::{Error, Result};
use crate::quant::{AttentionPool, Classifier, GatLayer, GatScales, GruCell, QLinear, QScale};

use super::parts::{layer_msg, LayerId, ModelFile};
use super::validate::{check_layer_shape, scale};

impl ModelFile {
    /// Layer `id` as an int8 kernel of the given sizes.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] unless `(IN, OUT)` is the layer's shape and its
    /// buffers have that shape; [`Error::ModelValue`] for a bad scale; the errors of
    /// [`QLinear::from_parts`].
    pub fn linear<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
    ) -> Result<QLinear<IN, OUT>> {
        if self.dims.layer_shape(id) != (IN, OUT) {
            return Err(Error::ModelDimensions(layer_msg!(
                id,
                "sizes asked for != the file's (inputs, outputs)"
            )));
        }
        self.linear_padded(id).map(|(l, _)| l)
    }

    /// Layer `id` with `IN` inputs and at most `OUT` outputs, padded to `OUT`
    /// outputs with zero rows (zero weights and bias, the first row's weight scale),
    /// and the file's output count: for heads whose size (classes, indicators) is
    /// only known at run time. A caller reads the first `outputs` values only.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] unless the file's layer has `IN` inputs and at most
    /// `OUT` outputs; otherwise as [`ModelFile::linear`].
    pub fn linear_padded<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
    ) -> Result<(QLinear<IN, OUT>, usize)> {
        let mut q = QLinear::EMPTY;
        let outputs = self.linear_into(id, &mut q)?;
        Ok((q, outputs))
    }

    /// [`ModelFile::linear_padded`] into a layer that already exists (e.g. inside a
    /// `static` network): no temporary of the layer's size. Returns the file's output
    /// count.
    ///
    /// # Errors
    /// As [`ModelFile::linear_padded`]. On error `out` is partly overwritten.
    // Not inlined (nor the GAT and GRU builders): inlined into `DsStgat::load`, their
    // locals added up to 2 212 B of stack on the Cortex-M4F; in their own frames the
    // build peaks at 1 668 B (`firmware-probe/`).
    #[inline(never)]
    pub fn linear_into<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
        out: &mut QLinear<IN, OUT>,
    ) -> Result<usize> {
        const { assert!(IN > 0 && OUT > 0, "a layer needs inputs and outputs") };
        let (inputs, outputs) = self.dims.layer_shape(id);
        if inputs != IN || outputs > OUT || outputs == 0 {
            return Err(Error::ModelDimensions(layer_msg!(
                id,
                "sizes asked for do not fit the file's (inputs, outputs)"
            )));
        }
        let l = self.layer(id);
        check_layer_shape(&self.dims, id, l)?;
        let bad_scale = layer_msg!(id, "a scale is not finite and > 0");
        let mut weight_scales = [QScale::UNIT; OUT];
        for (s, &v) in weight_scales.iter_mut().zip(l.weight_scales) {
            *s = scale(v, bad_scale)?;
        }
        out.set_parts(
            l.weights,
            &weight_scales[..outputs],
            l.bias,
            scale(l.input_scale, bad_scale)?,
            scale(l.output_scale, bad_scale)?,
        )?;
        Ok(outputs)
    }

    /// The GAT layer with `F` features and `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`]; [`Error::ModelDimensions`] for attention or bias
    /// vectors not of length `H`; [`Error::ModelValue`] for a bad scale; the errors of
    /// [`GatLayer::from_parts`].
    pub fn gat_layer<const F: usize, const H: usize>(&self) -> Result<GatLayer<F, H>> {
        let project = self.linear::<F, H>(LayerId::GatProject)?;
        let g = &self.gat;
        let dims = |what| Error::ModelDimensions(what);
        let a_src: [i8; H] = g
            .a_src
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.a_src length != GAT hidden size"))?;
        let a_dst: [i8; H] = g
            .a_dst
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.a_dst length != GAT hidden size"))?;
        let bias: [i32; H] = g
            .bias
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.bias length != GAT hidden size"))?;
        let bad = "gat: an attention or activation scale is not finite and > 0";
        let scales = GatScales {
            input: project.input_scale(),
            projected: project.output_scale(),
            logit: scale(g.logit_scale, bad)?,
            output: scale(g.output_scale, bad)?,
        };
        GatLayer::from_parts(
            project,
            (a_src, scale(g.a_src_scale, bad)?),
            (a_dst, scale(g.a_dst_scale, bad)?),
            bias,
            scales,
        )
    }

    /// [`ModelFile::gat_layer`] into an existing layer (no temporary of its size).
    ///
    /// # Errors
    /// As [`ModelFile::gat_layer`]. On error `out` is partly overwritten.
    #[inline(never)]
    pub fn gat_layer_into<const F: usize, const H: usize>(
        &self,
        out: &mut GatLayer<F, H>,
    ) -> Result<()> {
        if self.dims.layer_shape(LayerId::GatProject) != (F, H) {
            return Err(Error::ModelDimensions(
                "gat.project: sizes asked for != the file's (inputs, outputs)",
            ));
        }
        let g = &self.gat;
        let bad = "gat: an attention or activation scale is not finite and > 0";
        let dims = |e: Error, what| match e {
            Error::BufferSize { .. } => Error::ModelDimensions(what),
            other => other,
        };
        out.set_in_place(
            |p| self.linear_into(LayerId::GatProject, p).map(|_| ()),
            (&g.a_src, scale(g.a_src_scale, bad)?),
            (&g.a_dst, scale(g.a_dst_scale, bad)?),
            &g.bias,
            scale(g.logit_scale, bad)?,
            scale(g.output_scale, bad)?,
        )
        .map_err(|e| dims(e, "gat: a_src, a_dst or bias length != GAT hidden size"))
    }

    /// [`ModelFile::gru_cell`] into an existing cell (no temporary of its size).
    ///
    /// # Errors
    /// As [`ModelFile::gru_cell`]. On error `out` is partly overwritten.
    #[inline(never)]
    pub fn gru_cell_into<const IN: usize, const H: usize>(
        &self,
        out: &mut GruCell<IN, H>,
    ) -> Result<()> {
        const GATES: [(LayerId, LayerId); 3] = [
            (LayerId::GruWz, LayerId::GruUz),
            (LayerId::GruWr, LayerId::GruUr),
            (LayerId::GruWn, LayerId::GruUn),
        ];
        out.set_in_place(|g, w, u| {
            let (wid, uid) = GATES[g.min(2)];
            for (id, shape) in [(wid, (IN, H)), (uid, (H, H))] {
                if self.dims.layer_shape(id) != shape {
                    return Err(Error::ModelDimensions(layer_msg!(
                        id,
                        "sizes asked for != the file's (inputs, outputs)"
                    )));
                }
            }
            self.linear_into(wid, w)?;
            self.linear_into(uid, u)?;
            Ok(())
        })
    }

    /// The GRU cell with `IN` inputs (the GAT hidden size) and `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`] and [`GruCell::from_parts`].
    pub fn gru_cell<const IN: usize, const H: usize>(&self) -> Result<GruCell<IN, H>> {
        GruCell::from_parts(
            (
                self.linear::<IN, H>(LayerId::GruWz)?,
                self.linear::<H, H>(LayerId::GruUz)?,
            ),
            (
                self.linear::<IN, H>(LayerId::GruWr)?,
                self.linear::<H, H>(LayerId::GruUr)?,
            ),
            (
                self.linear::<IN, H>(LayerId::GruWn)?,
                self.linear::<H, H>(LayerId::GruUn)?,
            ),
        )
    }

    /// The attention pooling over `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`].
    pub fn attention_pool<const H: usize>(&self) -> Result<AttentionPool<H>> {
        Ok(AttentionPool::from_parts(
            self.linear::<H, 1>(LayerId::PoolScore)?,
        ))
    }

    /// The classifier from `H` hidden units to `C` classes.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`].
    pub fn classifier<const H: usize, const C: usize>(&self) -> Result<Classifier<H, C>> {
        Ok(Classifier::from_linear(
            self.linear::<H, C>(LayerId::Classifier)?,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model_file::testkit::{test_model, F, HG, HR};

    #[test]
    fn typed_sizes_must_match() {
        let d = test_model();
        assert!(matches!(
            d.gat_layer::<HG, 9>(),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.gru_cell::<HG, 4>(),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.classifier::<HR, 5>(),
            Err(Error::ModelDimensions(_))
        ));
        // U is H×H, and HG == HR here.
        assert!(d.linear::<HG, HR>(LayerId::GruUz).is_ok());
        assert!(matches!(
            d.linear::<F, HR>(LayerId::GruWz),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.graph_config::<4>(),
            Err(Error::ModelDimensions(_))
        ));
    }
}
