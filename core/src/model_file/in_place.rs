//! Deserialization straight into caller-owned storage.
//!
//! A derived `Deserialize` builds every field as a local and moves it into the
//! struct, level by level: decoding the ~32 KiB [`ModelFile`] that way took ~228 KiB
//! of stack in a release build (measured on x86-64), far beyond an MCU's. Here each
//! struct of the payload writes its fields into `place` and each `heapless::Vec`
//! pushes its elements into the existing buffer, so [`decode_into`](super::decode_into)
//! needs only a few KiB of stack whatever the model's size. Small leaf types (scalars,
//! names, [`Dimensions`], …) are built and assigned, as derived code would.

use core::fmt;

use heapless::{String, Vec};
use serde::de::{self, Deserialize, DeserializeSeed, Deserializer, SeqAccess, Visitor};

use super::parts::{
    DiagnosisParts, Dimensions, GatParts, GeometryParts, GraphParts, GruParts, IndicatorParts,
    ModelFile, NormParts, PhysicsParts, QLinearParts,
};

/// Deserialize into an existing value (postcard's sequence form of structs).
pub(super) trait DecodeInPlace<'de> {
    /// Overwrite `place` with the next value of `d`. On error `place` holds a
    /// partly overwritten, memory-safe but meaningless value.
    fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error>;
}

/// A [`DeserializeSeed`] that decodes into the borrowed value.
struct InPlace<'a, T>(&'a mut T);

impl<'de, T: DecodeInPlace<'de>> DeserializeSeed<'de> for InPlace<'_, T> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        T::decode_in_place(d, self.0)
    }
}

/// Small values: build and assign.
macro_rules! assign_in_place {
    ($($t:ty),+ $(,)?) => {$(
        impl<'de> DecodeInPlace<'de> for $t {
            fn decode_in_place<D: serde::Deserializer<'de>>(
                d: D,
                place: &mut Self,
            ) -> core::result::Result<(), D::Error> {
                *place = <$t as serde::Deserialize<'de>>::deserialize(d)?;
                Ok(())
            }
        }
    )+};
}

impl<'de, const N: usize> DecodeInPlace<'de> for String<N> {
    fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error> {
        *place = Self::deserialize(d)?;
        Ok(())
    }
}

/// A `heapless::Vec` fills its own buffer: no temporary of its capacity.
impl<'de, T: Deserialize<'de>, const N: usize> DecodeInPlace<'de> for Vec<T, N> {
    fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error> {
        struct Fill<'a, T, const N: usize>(&'a mut Vec<T, N>);
        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for Fill<'_, T, N> {
            type Value = ();
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "a sequence of at most {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
                self.0.clear();
                while let Some(v) = seq.next_element::<T>()? {
                    if self.0.push(v).is_err() {
                        return Err(de::Error::invalid_length(N + 1, &self));
                    }
                }
                Ok(())
            }
        }
        d.deserialize_seq(Fill(place))
    }
}

/// Decode a struct field by field into place (fields in declaration order, which
/// is the order `derive(Serialize)` writes), and give it a `Deserialize` impl
/// built on that. The destructuring pattern fails to compile if a field is
/// missing from the list.
macro_rules! struct_in_place {
    ($name:ident $(<$(const $g:ident: usize),+>)? { $($field:ident),+ $(,)? }) => {
        impl<'de $($(, const $g: usize)+)?> DecodeInPlace<'de>
            for $name $(<$($g),+>)?
        {
            fn decode_in_place<D: serde::Deserializer<'de>>(
                d: D,
                place: &mut Self,
            ) -> core::result::Result<(), D::Error> {
                struct Fields<'a $($(, const $g: usize)+)?>(&'a mut $name $(<$($g),+>)?);
                impl<'de $($(, const $g: usize)+)?> serde::de::Visitor<'de>
                    for Fields<'_ $($(, $g)+)?>
                {
                    type Value = ();
                    fn expecting(
                        &self,
                        f: &mut core::fmt::Formatter<'_>,
                    ) -> core::fmt::Result {
                        f.write_str(concat!("struct ", stringify!($name)))
                    }
                    fn visit_seq<A: serde::de::SeqAccess<'de>>(
                        self,
                        mut seq: A,
                    ) -> core::result::Result<(), A::Error> {
                        let $name { $($field),+ } = self.0;
                        let mut index = 0usize;
                        $(
                            if seq
                                .next_element_seed(InPlace($field))?
                                .is_none()
                            {
                                return Err(serde::de::Error::invalid_length(
                                    index,
                                    &concat!("struct ", stringify!($name)),
                                ));
                            }
                            index += 1;
                        )+
                        let _ = index;
                        Ok(())
                    }
                }
                const FIELDS: &[&str] = &[$(stringify!($field)),+];
                d.deserialize_struct(stringify!($name), FIELDS, Fields(place))
            }
        }

        impl<'de $($(, const $g: usize)+)?> serde::Deserialize<'de> for $name $(<$($g),+>)? {
            fn deserialize<D: serde::Deserializer<'de>>(
                d: D,
            ) -> core::result::Result<Self, D::Error> {
                let mut value = Self::default();
                DecodeInPlace::decode_in_place(d, &mut value)?;
                Ok(value)
            }
            fn deserialize_in_place<D: serde::Deserializer<'de>>(
                d: D,
                place: &mut Self,
            ) -> core::result::Result<(), D::Error> {
                DecodeInPlace::decode_in_place(d, place)
            }
        }
    };
}

// The payload's types, leaves first.
assign_in_place!(
    f32,
    Dimensions,
    NormParts,
    GraphParts,
    PhysicsParts,
    GeometryParts,
    DiagnosisParts
);
struct_in_place!(QLinearParts<const W: usize, const CH: usize> {
    input_scale,
    output_scale,
    weight_scales,
    bias,
    weights,
});
struct_in_place!(GatParts {
    project,
    a_src,
    a_src_scale,
    a_dst,
    a_dst_scale,
    bias,
    logit_scale,
    output_scale,
});
struct_in_place!(GruParts {
    w_z,
    u_z,
    w_r,
    u_r,
    w_n,
    u_n,
});
struct_in_place!(IndicatorParts {
    names,
    mean,
    std,
    head,
});
struct_in_place!(ModelFile {
    model_name,
    created,
    dims,
    class_names,
    sensor_names,
    feature_norm,
    graph,
    embed,
    gat,
    gru,
    pool,
    classifier,
    sensor_head,
    indicator,
    physics,
    geometry,
    diagnosis,
});
