//! The serial bridge as a [`FrameSource`]: a serial port's bytes through the
//! wire format's streaming decoder.

use std::io::Read;

use serialport::SerialPort;

use super::{secs, DriverConfig, FrameSource, LinkError};
use crate::biotac::wire::{DecodedFrame, Decoder, DecoderStats};

/// A serial port and the decoder of its byte stream.
pub struct SerialSource {
    path: String,
    baud: u32,
    timeout_s: f64,
    port: Option<Box<dyn SerialPort>>,
    decoder: Decoder,
    buf: Vec<u8>,
}

impl SerialSource {
    /// The port `config.port` at `config.baud`, not yet open.
    pub fn new(config: &DriverConfig) -> Self {
        SerialSource {
            path: config.port.clone(),
            baud: config.baud,
            timeout_s: config.read_timeout_s,
            port: None,
            decoder: Decoder::new(),
            buf: vec![0; 4096],
        }
    }
}

impl FrameSource for SerialSource {
    fn name(&self) -> String {
        self.path.clone()
    }

    fn open(&mut self) -> Result<String, LinkError> {
        let port = serialport::new(self.path.as_str(), self.baud)
            .timeout(secs(self.timeout_s))
            .open()
            .map_err(|e| LinkError::Lost(e.to_string()))?;
        self.port = Some(port);
        Ok(self.path.clone())
    }

    fn read(&mut self, _timeout_s: f64, frames: &mut Vec<DecodedFrame>) -> Result<(), LinkError> {
        let Some(port) = self.port.as_mut() else {
            return Err(LinkError::Lost("not open".into()));
        };
        let n = match port.read(&mut self.buf) {
            Ok(0) => Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "end of stream",
            )),
            Ok(n) => Ok(n),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Ok(0),
            Err(e) => Err(e),
        }
        .map_err(|e| LinkError::Lost(e.to_string()))?;
        self.decoder.push(&self.buf[..n], |f| frames.push(f));
        Ok(())
    }

    fn close(&mut self) {
        self.port = None;
    }

    fn stats(&self) -> DecoderStats {
        self.decoder.stats()
    }
}
