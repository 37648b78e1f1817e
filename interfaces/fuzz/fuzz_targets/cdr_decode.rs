//! Any bytes decoded as every generated type: an error or a value, never a panic; a value
//! re-encodes and decodes again to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lewis_interfaces::cdr;
use lewis_interfaces::msg::*;

macro_rules! decode_all {
    ($($ty:ident),* $(,)?) => {
        fn decode_all(data: &[u8]) {
            $(
                if let Ok(value) = cdr::from_bytes::<$ty>(data) {
                    // The input may be non-canonical (padding bytes, booleans other
                    // than 0 and 1); its re-encoding is canonical and stable.
                    let again = cdr::to_vec(&value);
                    let value2: $ty = cdr::from_bytes(&again).expect("a canonical encoding decodes");
                    assert_eq!(cdr::to_vec(&value2), again);
                }
            )*
        }
    };
}

lewis_interfaces::for_each_struct!(decode_all);

fuzz_target!(|data: &[u8]| {
    let mut framed = cdr::ENCAPSULATION_LE.to_vec();
    framed.extend_from_slice(data);
    decode_all(&framed);
});
