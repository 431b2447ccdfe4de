//! The BioTac fingertip: reading type, its ROS message and the hands'
//! messages, tare, serial wire codec and driver, the SPI protocol and the Cheetah adapter that reads it,
//! a bridge emulator, and a simulator (forward model).

pub mod cheetah;
pub mod driver;
pub mod emulator;
pub mod geometry;
pub mod hand;
pub mod msg;
pub mod reading;
pub mod sim;
pub mod spi;
pub mod tare;
pub mod wire;

pub use driver::HoldLastGood;
pub use reading::{
    BioTacReading, ElectrodeLayout, Electrodes, Pac, ADC_MAX, FRAME_PERIOD_S, MAX_ELECTRODES,
    MAX_PAC, N_ELECTRODES, N_PAC,
};
pub use sim::{BioTacSim, BioTacSimConfig, Contact};
pub use tare::{Tare, TareError};
pub use wire::{ChannelMask, DecodedFrame, Decoder, DecoderStats, FrameError, WordError};
