//! The names of the network's layers, which most engine modules share: defined here, below
//! them, so that their imports run one way.

use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};

/// The five layers, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layer {
    Conv1,
    Pool1,
    Conv2,
    Pool2,
    Conv3,
}

impl Layer {
    /// All layers in order.
    pub const ALL: [Layer; 5] = [
        Layer::Conv1,
        Layer::Pool1,
        Layer::Conv2,
        Layer::Pool2,
        Layer::Conv3,
    ];

    /// Index in [`Layer::ALL`] (and in spike counts).
    pub fn index(self) -> usize {
        self as usize
    }

    /// `"conv1"`, `"pool1"`, ...
    pub fn name(self) -> &'static str {
        ["conv1", "pool1", "conv2", "pool2", "conv3"][self.index()]
    }
}

impl fmt::Display for Layer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The three trainable (conv) layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConvLayer {
    Conv1,
    Conv2,
    Conv3,
}

impl ConvLayer {
    /// All conv layers in order.
    pub const ALL: [ConvLayer; 3] = [ConvLayer::Conv1, ConvLayer::Conv2, ConvLayer::Conv3];

    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// `"conv1"`, `"conv2"` or `"conv3"`.
    pub fn name(self) -> &'static str {
        ["conv1", "conv2", "conv3"][self.index()]
    }
}

impl fmt::Display for ConvLayer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ConvLayer {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        ConvLayer::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| {
                Error::param(
                    "layer",
                    format!("must be one of conv1, conv2, conv3, got {s:?}"),
                )
            })
    }
}
