//! Decoding verified frame bytes into a request or a response; trailing bytes are an error.

use super::replies::Response;
use super::requests::Request;

/// A request that passed its CRC but did not decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Malformed {
    /// The leading seq, if at least that could be read.
    pub seq: Option<u32>,
}

/// Decodes a request from verified frame bytes; trailing bytes are an error.
pub fn decode_request(msg: &[u8]) -> Result<Request, Malformed> {
    match postcard::take_from_bytes::<Request>(msg) {
        Ok((req, [])) => Ok(req),
        _ => Err(Malformed { seq: postcard::take_from_bytes::<u32>(msg).ok().map(|(s, _)| s) }),
    }
}

/// Decodes a response from verified frame bytes; trailing bytes are an error.
pub fn decode_response(msg: &[u8]) -> Option<Response> {
    match postcard::take_from_bytes::<Response>(msg) {
        Ok((resp, [])) => Some(resp),
        _ => None,
    }
}
