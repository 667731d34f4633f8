//! pumptwin host side.
