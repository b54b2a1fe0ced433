//! Arbitrary bytes into both stream decoders: no input may panic, and every
//! message that comes out must re-encode to a frame that decodes to the same
//! message (compared as frame bytes, so NaN payloads compare bit for bit).
#![no_main]

use libfuzzer_sys::fuzz_target;
use serde::{de::DeserializeOwned, Serialize};
use urechis::protocol::{encode, DeviceMessage, FrameDecoder, HostMessage, MAX_FRAME};

fuzz_target!(|data: &[u8]| {
    let mut device = FrameDecoder::<DeviceMessage>::new();
    let mut host = FrameDecoder::<HostMessage>::new();
    for &byte in data {
        if let Some(Ok(msg)) = device.push(byte) {
            assert_reencodes(&msg);
        }
        if let Some(Ok(msg)) = host.push(byte) {
            assert_reencodes(&msg);
        }
    }
});

fn assert_reencodes<T: Serialize + DeserializeOwned>(msg: &T) {
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(msg, &mut buf).expect("a decoded message always fits a frame");
    let mut decoder = FrameDecoder::<T>::new();
    let mut decoded = frame.iter().filter_map(|&b| decoder.push(b));
    let again = decoded
        .next()
        .expect("one result")
        .expect("own frame decodes");
    assert!(decoded.next().is_none());
    let mut buf2 = [0u8; MAX_FRAME];
    assert_eq!(encode(&again, &mut buf2).expect("fits"), frame);
}
