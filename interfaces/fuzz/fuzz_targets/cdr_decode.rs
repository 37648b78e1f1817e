//! Any bytes decoded as every generated type: an error or a value, never a panic; a value
//! re-encodes and decodes again to the same bytes. The type's view (read in place) agrees:
//! the same error, or a view whose owned value encodes to the same bytes. Written in place
//! over stale bytes, arrays filled afterwards, a decoded value encodes to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lewis_interfaces::{InPlace, Struct};
use lewis_interfaces::cdr::{self, ViewToOwned};
use lewis_interfaces::msg::*;

macro_rules! decode_all {
    ($($ty:ident),* $(,)?) => {
        fn decode_all(data: &[u8]) {
            $(
                let decoded = cdr::from_bytes::<$ty>(data);
                match (&decoded, <$ty as Struct>::view(data)) {
                    (Ok(value), Ok(view)) => {
                        assert_eq!(cdr::to_vec(&view.to_owned_value()), cdr::to_vec(value));
                    }
                    (Err(d), Err(v)) => assert_eq!(d, &v),
                    (d, v) => panic!("decode {:?} but view {:?}", d.as_ref().err(), v.err()),
                }
                if let Ok(value) = decoded {
                    // The input may be non-canonical (padding bytes, booleans other
                    // than 0 and 1); its re-encoding is canonical and stable.
                    let again = cdr::to_vec(&value);
                    let value2: $ty = cdr::from_bytes(&again).expect("a canonical encoding decodes");
                    assert_eq!(cdr::to_vec(&value2), again);
                    let lens = value.bulk_lens();
                    let mut loan = vec![0xA5; cdr::in_place_len(&value, &lens)];
                    let bulk = cdr::encode_in_place(&value, &lens, &mut loan).expect("sized by in_place_len");
                    value.write_bulk(bulk);
                    assert_eq!(loan, again);
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
