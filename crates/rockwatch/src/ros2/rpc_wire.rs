//! The wire of a ROS 2 service call in the two request/reply mappings the node answers on one
//! pair of topics (`rq/<service>Request`, `rr/<service>Reply`):
//!
//! - **enhanced** (rmw_fastrtps — ROS 2's default —, rmw_connextdds, ros2-client): the payload
//!   is the request alone, CDR; the reply is the response alone and names its request in the
//!   inline QoS `PID_RELATED_SAMPLE_IDENTITY`.
//! - **rmw_cyclonedds**: the payload starts with a 16-byte header, the client's 64-bit id and
//!   the request's sequence number (CDR `uint64`, `int64`; rmw_cyclonedds's
//!   `cdds_request_header_t`), then the request; the reply starts with the same header, by
//!   which the client recognises its response.
//!
//! A request is read as whichever mapping decodes it exactly: all of its payload, up to the
//! 3 bytes of CDR padding a writer may add. Enhanced is tried first. A payload both decode
//! exactly would be a request whose own bytes from offset 16 on also form a request, whose
//! first 8 bytes then would have to be a client id whose low half is a valid length: such a
//! request is taken as enhanced (rmw_cyclonedds's client ids are pseudo-random 64-bit
//! handles: one of its requests reads as enhanced with a probability of about 2⁻³² per byte
//! of payload).

use ros2_client::dds::rustdds::bytes::Bytes;
use ros2_client::dds::rustdds::no_key::{
    Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter,
};
use ros2_client::dds::rustdds::serialization::{
    deserialize_from_cdr_with_rep_id, to_writer_with_rep_id,
};
use ros2_client::dds::rustdds::{RepresentationIdentifier, SampleIdentity, SequenceNumber, GUID};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Bytes of rmw_cyclonedds's request/reply header.
pub const CYCLONE_HEADER_BYTES: usize = 16;

/// The serialized payload of one sample and its CDR byte order, as on the wire (the reader
/// and writer of a dual-mapping server pass it through untouched: [`WireAdapter`]).
#[derive(Debug, Clone)]
pub struct Wire {
    pub bytes: Bytes,
    pub encoding: RepresentationIdentifier,
}

/// How the reply to a request must be framed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// The response alone; the request named in the inline QoS.
    Enhanced(SampleIdentity),
    /// rmw_cyclonedds's header (the client's id, the request's number), then the response.
    Cyclone { client: u64, sequence: i64 },
}

/// Which request a reply answers, and to whom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestId {
    /// The request's writer: its GUID prefix names the requesting participant, whose response
    /// reader is looked for in discovery before the reply is sent.
    pub client: GUID,
    pub framing: Framing,
}

/// The request writer, its sequence number and the related sample identity (inline QoS) of
/// one received request sample.
#[derive(Debug, Clone, Copy)]
pub struct SampleMeta {
    pub writer: GUID,
    pub sequence: SequenceNumber,
    pub related: Option<SampleIdentity>,
}

/// Why a request was not read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a {bytes}-byte request that is neither an enhanced-mapping request nor an rmw_cyclonedds one ({enhanced}; {cyclone})")]
pub struct UndecodableRequest {
    pub bytes: usize,
    pub enhanced: String,
    pub cyclone: String,
}

/// `R` decoded from all of `bytes` (up to 3 bytes of padding), or why not.
fn decode_exactly<R: DeserializeOwned>(
    bytes: &[u8],
    encoding: RepresentationIdentifier,
) -> Result<R, String> {
    let (value, used) =
        deserialize_from_cdr_with_rep_id::<R>(bytes, encoding).map_err(|e| format!("{e}"))?;
    let rest = bytes.len().saturating_sub(used);
    if rest > 3 {
        return Err(format!("{rest} bytes left over"));
    }
    Ok(value)
}

/// Reads one request sample in whichever mapping decodes it (see the module's docs).
pub fn decode_request<R: DeserializeOwned>(
    wire: &Wire,
    meta: SampleMeta,
) -> Result<(RequestId, R), UndecodableRequest> {
    let client = meta.writer;
    let enhanced = match decode_exactly::<R>(&wire.bytes, wire.encoding) {
        Ok(request) => {
            // Fast DDS names the client's response reader with an unknown sequence number;
            // ros2-client's enhanced clients name nothing: the sample's own identity then.
            let mut id = meta.related.unwrap_or(SampleIdentity {
                writer_guid: meta.writer,
                sequence_number: meta.sequence,
            });
            if id.sequence_number == SequenceNumber::UNKNOWN {
                id.sequence_number = meta.sequence;
            }
            let framing = Framing::Enhanced(id);
            return Ok((RequestId { client, framing }, request));
        }
        Err(e) => e,
    };
    let cyclone = match decode_cyclone::<R>(wire) {
        Ok((framing, request)) => return Ok((RequestId { client, framing }, request)),
        Err(e) => e,
    };
    Err(UndecodableRequest {
        bytes: wire.bytes.len(),
        enhanced,
        cyclone,
    })
}

/// rmw_cyclonedds's header and request.
fn decode_cyclone<R: DeserializeOwned>(wire: &Wire) -> Result<(Framing, R), String> {
    if wire.bytes.len() < CYCLONE_HEADER_BYTES {
        return Err(format!(
            "shorter than the {CYCLONE_HEADER_BYTES}-byte header"
        ));
    }
    let ((client, sequence), _) =
        deserialize_from_cdr_with_rep_id::<(u64, i64)>(&wire.bytes, wire.encoding)
            .map_err(|e| format!("header: {e}"))?;
    // The header is 8-aligned: the request's CDR alignment starts again after it.
    let request = decode_exactly::<R>(&wire.bytes[CYCLONE_HEADER_BYTES..], wire.encoding)?;
    Ok((Framing::Cyclone { client, sequence }, request))
}

/// A service reply that could not be serialized to CDR (the serializer's message).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ReplyEncodeError(pub String);

impl From<String> for ReplyEncodeError {
    fn from(reason: String) -> Self {
        ReplyEncodeError(reason)
    }
}

impl From<&str> for ReplyEncodeError {
    fn from(reason: &str) -> Self {
        ReplyEncodeError(reason.to_owned())
    }
}

/// The payload of the reply `response` to `id` (little-endian CDR, as the writer declares).
pub fn encode_reply<S: Serialize>(id: &RequestId, response: &S) -> Result<Wire, ReplyEncodeError> {
    let encoding = RepresentationIdentifier::CDR_LE;
    let mut out = Vec::with_capacity(64);
    if let Framing::Cyclone { client, sequence } = id.framing {
        to_writer_with_rep_id(&mut out, &(client, sequence), encoding)
            .map_err(|e| format!("{e}"))?;
    }
    to_writer_with_rep_id(&mut out, response, encoding).map_err(|e| format!("{e}"))?;
    Ok(Wire {
        bytes: Bytes::from(out),
        encoding,
    })
}

/// The serializer and deserializer adapter of [`Wire`]: bytes in, bytes out.
pub struct WireAdapter;

/// [`WireAdapter`]'s decoder (it copies the payload).
#[derive(Clone)]
pub struct WireDecoder;

impl DeserializerAdapter<Wire> for WireAdapter {
    type Error = std::convert::Infallible;
    type Decoded = Wire;
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[
            RepresentationIdentifier::CDR_LE,
            RepresentationIdentifier::CDR_BE,
        ]
    }
    fn transform_decoded(decoded: Wire) -> Wire {
        decoded
    }
}

impl DefaultDecoder<Wire> for WireAdapter {
    type Decoder = WireDecoder;
    const DECODER: WireDecoder = WireDecoder;
}

impl<'de> Decode<'de, Wire> for WireDecoder {
    type Error = std::convert::Infallible;
    fn decode_bytes(
        self,
        input_bytes: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> Result<Wire, Self::Error> {
        Ok(Wire {
            bytes: Bytes::copy_from_slice(input_bytes),
            encoding,
        })
    }
}

impl SerializerAdapter<Wire> for WireAdapter {
    type Error = std::convert::Infallible;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &Wire) -> Result<Bytes, Self::Error> {
        Ok(value.bytes.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct Reset {
        pbr_id: String,
    }

    fn meta(related: Option<SampleIdentity>) -> SampleMeta {
        SampleMeta {
            writer: GUID::from_bytes([7; 16]),
            sequence: SequenceNumber::from(5_i64),
            related,
        }
    }

    /// Little-endian CDR written by hand (not by the serializer under test).
    fn le_string(s: &str) -> Vec<u8> {
        let mut b = ((s.len() + 1) as u32).to_le_bytes().to_vec();
        b.extend_from_slice(s.as_bytes());
        b.push(0);
        b
    }

    fn wire(bytes: Vec<u8>) -> Wire {
        Wire {
            bytes: Bytes::from(bytes),
            encoding: RepresentationIdentifier::CDR_LE,
        }
    }

    #[test]
    fn an_enhanced_request_is_answered_by_the_identity_it_names_or_its_own() {
        let w = wire(le_string("rrs-slender-pillar"));
        let (id, r) = decode_request::<Reset>(&w, meta(None)).unwrap();
        assert_eq!(r.pbr_id, "rrs-slender-pillar");
        assert_eq!(id.client, GUID::from_bytes([7; 16]));
        let Framing::Enhanced(si) = id.framing else {
            panic!("{id:?}")
        };
        assert_eq!(si.writer_guid, meta(None).writer);
        assert_eq!(si.sequence_number, SequenceNumber::from(5_i64));
        // Fast DDS: the client's reader, sequence number unknown → the sample's own number.
        let reader = GUID::from_bytes([8; 16]);
        let named = SampleIdentity {
            writer_guid: reader,
            sequence_number: SequenceNumber::UNKNOWN,
        };
        let (id, _) = decode_request::<Reset>(&w, meta(Some(named))).unwrap();
        assert_eq!(
            id.framing,
            Framing::Enhanced(SampleIdentity {
                writer_guid: reader,
                sequence_number: SequenceNumber::from(5_i64)
            })
        );
        // The reply is the response alone.
        let reply = encode_reply(&id, &Reset { pbr_id: "x".into() }).unwrap();
        assert_eq!(&reply.bytes[..], &le_string("x")[..]);
    }

    #[test]
    fn an_rmw_cyclonedds_request_is_answered_with_its_header() {
        let client: u64 = 0x9a3c_71e2_5b04_d8f1;
        let mut bytes = client.to_le_bytes().to_vec();
        bytes.extend_from_slice(&42_i64.to_le_bytes());
        bytes.extend_from_slice(&le_string("rrs-slender-pillar"));
        let (id, r) = decode_request::<Reset>(&wire(bytes.clone()), meta(None)).unwrap();
        assert_eq!(r.pbr_id, "rrs-slender-pillar");
        assert_eq!(
            id.framing,
            Framing::Cyclone {
                client,
                sequence: 42
            }
        );
        let reply = encode_reply(&id, &Reset { pbr_id: "x".into() }).unwrap();
        let mut expected = bytes[..16].to_vec();
        expected.extend_from_slice(&le_string("x"));
        assert_eq!(&reply.bytes[..], &expected[..]);
    }

    #[test]
    fn big_endian_cyclone_headers_are_read_in_their_order() {
        let mut bytes = 0x0102_0304_0506_0708_u64.to_be_bytes().to_vec();
        bytes.extend_from_slice(&3_i64.to_be_bytes());
        bytes.extend_from_slice(&2_u32.to_be_bytes());
        bytes.extend_from_slice(b"a\0");
        let w = Wire {
            bytes: Bytes::from(bytes),
            encoding: RepresentationIdentifier::CDR_BE,
        };
        let (id, r) = decode_request::<Reset>(&w, meta(None)).unwrap();
        assert_eq!(r.pbr_id, "a");
        assert_eq!(
            id.framing,
            Framing::Cyclone {
                client: 0x0102_0304_0506_0708,
                sequence: 3
            }
        );
    }

    #[test]
    fn a_payload_that_is_neither_says_why_for_both() {
        let e = decode_request::<Reset>(&wire(vec![0xff; 9]), meta(None)).unwrap_err();
        assert_eq!(e.bytes, 9);
        assert!(e.cyclone.contains("16-byte header"), "{e}");
        // A request with bytes left over is not taken as one.
        let mut b = le_string("a");
        b.extend_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        let e = decode_request::<Reset>(&wire(b), meta(None)).unwrap_err();
        assert!(e.enhanced.contains("left over"), "{e}");
    }
}
