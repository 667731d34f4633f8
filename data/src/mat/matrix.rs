//! One `miMATRIX` element: array flags, dimensions and name, then the contents by
//! class (a numeric array, a char array, a struct, or a skipped entry).

use super::error::{MatError, Position};
use super::stream::{data_type, Body, Element, Stream};
use super::types::{MatClass, MatFile, MatText, MatVariable, SkipReason, SkippedVariable};

/// Array-flags bit that marks a complex array.
const FLAG_COMPLEX: u32 = 0x0800;

impl<'a> Stream<'a> {
    /// Parse one `miMATRIX` element into `out`: a numeric array into
    /// [`MatFile::variables`], a char array into [`MatFile::texts`], a struct's fields
    /// recursively, anything else into [`MatFile::skipped`]. `field` is the full name
    /// (`s.field`) of a struct field at nesting `depth` (0 at top level, where the
    /// stored name is used).
    pub(super) fn matrix(
        &self,
        element: &Element<'a>,
        field: Option<&str>,
        depth: usize,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
        let at = self.pos(element.start);
        if element.data.is_empty() {
            out.skipped.push(SkippedVariable {
                name: field.unwrap_or_default().to_string(),
                at,
                reason: SkipReason::EmptyMatrix,
            });
            return Ok(());
        }
        let end = element.data_start + element.data.len();
        let (flags, class, offset) = self.array_flags(element.data_start, end, field)?;

        if !class.is_numeric() && !matches!(class, MatClass::Struct | MatClass::Char) {
            // Layouts differ by class (opaque objects have no dimensions); take the
            // name where it can be found and move on.
            let name = match field {
                Some(f) => f.to_string(),
                None => self.name_best_effort(offset, end),
            };
            out.skipped.push(SkippedVariable {
                name,
                at,
                reason: SkipReason::UnsupportedClass(class),
            });
            return Ok(());
        }

        let (dims, offset) = self.dimensions(offset, end, at, field)?;
        let (name, offset) = self.array_name(offset, end, at, field)?;

        if class.is_numeric() && flags & FLAG_COMPLEX != 0 {
            out.skipped.push(SkippedVariable {
                name,
                at,
                reason: SkipReason::Complex,
            });
            return Ok(());
        }

        let expected = value_count(&dims, at, &name)?;
        let body = Body {
            at,
            offset,
            end,
            expected,
        };
        self.contents(&body, class, name, dims, depth, out)
    }

    /// The array flags (miUINT32, two words: flags, nzmax) at `offset`: the flags, the
    /// class they give, and the offset just past them.
    fn array_flags(
        &self,
        offset: usize,
        end: usize,
        field: Option<&str>,
    ) -> Result<(u32, MatClass, usize), MatError> {
        let flags_el = self.element(offset, Some(end), "array flags")?;
        if flags_el.data_type != data_type::UINT32 || flags_el.data.len() < 4 {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(flags_el.start),
                name: field.unwrap_or_default().to_string(),
                what: "array flags",
                data_type: flags_el.data_type,
                expected: "miUINT32 with at least 4 bytes",
            });
        }
        let flags = self.u32_at(flags_el.data_start);
        Ok((flags, MatClass::from_flags(flags), flags_el.next))
    }

    /// The dimensions (miINT32, at least one) at `offset` of the matrix at `at`, and the
    /// offset just past them.
    fn dimensions(
        &self,
        offset: usize,
        end: usize,
        at: Position,
        field: Option<&str>,
    ) -> Result<(Vec<usize>, usize), MatError> {
        if offset >= end {
            return Err(MatError::MissingSubelement {
                at,
                name: field.unwrap_or_default().to_string(),
                what: "dimensions",
            });
        }
        let dims_el = self.element(offset, Some(end), "dimensions")?;
        let dims = self.dims(&dims_el, at)?;
        Ok((dims, dims_el.next))
    }

    /// The array name (miINT8 ASCII, possibly in the small format) at `offset`, and the
    /// offset just past it. A struct field's own name is empty; it is named after
    /// `field` instead.
    fn array_name(
        &self,
        offset: usize,
        end: usize,
        at: Position,
        field: Option<&str>,
    ) -> Result<(String, usize), MatError> {
        if offset >= end {
            return Err(MatError::MissingSubelement {
                at,
                name: field.unwrap_or_default().to_string(),
                what: "array name",
            });
        }
        let name_el = self.text_element(offset, end, field.unwrap_or_default(), "array name")?;
        let name = match field {
            Some(f) => f.to_string(),
            None => String::from_utf8_lossy(name_el.data).into_owned(),
        };
        Ok((name, name_el.next))
    }

    /// What follows the name, by class: a struct's fields, a char array's text, or a
    /// numeric array's real part.
    fn contents(
        &self,
        body: &Body,
        class: MatClass,
        name: String,
        dims: Vec<usize>,
        depth: usize,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
        match class {
            MatClass::Struct => self.structure(body, &name, depth, out),
            MatClass::Char => {
                let text = self.text(body, &name, &dims)?;
                out.texts.push(MatText { name, dims, text });
                Ok(())
            }
            _ => self.real_array(body, class, name, dims, out),
        }
    }

    /// The real part of a numeric array (an empty array may omit it), into
    /// [`MatFile::variables`].
    fn real_array(
        &self,
        body: &Body,
        class: MatClass,
        name: String,
        dims: Vec<usize>,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
        let Body {
            at,
            offset,
            end,
            expected,
        } = *body;
        let data = if offset >= end {
            if expected != 0 {
                return Err(MatError::MissingSubelement {
                    at,
                    name,
                    what: "real part",
                });
            }
            Vec::new()
        } else {
            let real_el = self.element(offset, Some(end), "real part")?;
            self.numeric(&real_el, &name, "real part")?
        };
        if data.len() != expected {
            return Err(MatError::DataLength {
                at,
                name,
                dims,
                expected,
                got: data.len(),
            });
        }
        out.variables.push(MatVariable {
            name,
            dims,
            data,
            class,
        });
        Ok(())
    }
}

/// The number of values (or struct elements) that dimensions `dims` call for.
fn value_count(dims: &[usize], at: Position, name: &str) -> Result<usize, MatError> {
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| MatError::BadDims {
            at,
            name: name.to_string(),
            reason: format!("the product of {dims:?} overflows"),
        })
}
