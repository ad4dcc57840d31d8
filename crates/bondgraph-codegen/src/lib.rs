//! bondgraph-codegen: what bgc writes from a model. One module per output format.

pub mod c;
pub mod dot;
pub mod fmu;
pub mod json;
pub mod latex;
mod names;
pub mod rust;
mod shared;
mod sharing;
mod signals;
pub mod text;
