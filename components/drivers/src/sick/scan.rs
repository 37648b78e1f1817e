//! B0 scans: the values with their flags, the range unit, and the angles of the values.

use super::SickError;

/// The B0 reply code.
pub(crate) const SCAN_REPLY: u8 = 0xB0;

/// The most values one B0 telegram can carry within [`super::MAX_PAYLOAD_LEN`]
/// (reply code, count word, values, status).
pub const MAX_SCAN_VALUES: usize = (super::MAX_PAYLOAD_LEN - 4) / 2;

const COUNT_MASK: u16 = 0x03FF;
const COUNT_FLAGS_MASK: u16 = 0x3C00;
const UNIT_SHIFT: u16 = 14;

/// The unit of a scan's ranges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RangeUnit {
    /// Centimetres (B0 unit bits 00; config unit byte 0).
    Centimetre,
    /// Millimetres (B0 unit bits 01; config unit byte 1); ranges up to 8.191 m.
    Millimetre,
    /// Decimetres (B0 unit bits 10): guessed from the LMS manual as read by sicktoolbox.
    Decimetre,
}

impl RangeUnit {
    /// Metres per unit.
    pub fn metres(self) -> f64 {
        match self {
            Self::Centimetre => 0.01,
            Self::Millimetre => 0.001,
            Self::Decimetre => 0.1,
        }
    }

    /// The two unit bits of a B0 count word (bits 14-15).
    pub fn scan_bits(self) -> u8 {
        match self {
            Self::Centimetre => 0,
            Self::Millimetre => 1,
            Self::Decimetre => 2,
        }
    }

    /// The unit of the two B0 unit bits.
    pub fn from_scan_bits(bits: u8) -> Result<Self, SickError> {
        match bits {
            0 => Ok(Self::Centimetre),
            1 => Ok(Self::Millimetre),
            2 => Ok(Self::Decimetre),
            code => Err(SickError::UnknownUnit { code }),
        }
    }
}

/// One measured value as sent: a 13-bit range and 3 flag bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScanValue(pub u16);

impl ScanValue {
    /// The largest range a value can carry, in the scan's unit.
    pub const MAX_RANGE: u16 = 0x1FFF;

    /// A value from a range (clamped to [`Self::MAX_RANGE`]) and flags (low 3 bits kept).
    pub fn new(range: u16, flags: u8) -> Self {
        Self((range.min(Self::MAX_RANGE)) | (u16::from(flags & 0x07) << 13))
    }

    /// The range in the scan's unit: the low 13 bits.
    pub fn range(self) -> u16 {
        self.0 & Self::MAX_RANGE
    }

    /// The top 3 bits (field or dazzle flags, meaning depends on the scanner's settings).
    pub fn flags(self) -> u8 {
        (self.0 >> 13) as u8
    }

    /// The range in metres.
    pub fn range_m(self, unit: RangeUnit) -> f64 {
        f64::from(self.range()) * unit.metres()
    }
}

/// A decoded B0 scan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scan {
    /// The unit of every value's range.
    pub unit: RangeUnit,
    /// Bits 10-13 of the count word, kept as sent (partial-scan information; uninterpreted).
    pub count_flags: u8,
    /// The values in angular order (right to left, see [`ScanLayout::angle_rad`]).
    pub values: Vec<ScanValue>,
}

impl Scan {
    /// The ranges in metres, in order.
    pub fn ranges_m(&self) -> Vec<f64> {
        self.values
            .iter()
            .map(|value| value.range_m(self.unit))
            .collect()
    }

    /// Decodes the data between the B0 code and the status byte.
    pub(crate) fn decode_data(data: &[u8]) -> Result<Self, SickError> {
        let [count_lo, count_hi, values @ ..] = data else {
            return Err(SickError::Truncated {
                what: "B0 count",
                needed: 2,
                got: data.len(),
            });
        };
        let word = u16::from_le_bytes([*count_lo, *count_hi]);
        let declared = usize::from(word & COUNT_MASK);
        if values.len() != declared * 2 {
            return Err(SickError::ScanCountMismatch {
                declared,
                actual: values.len() / 2,
            });
        }
        Ok(Self {
            unit: RangeUnit::from_scan_bits((word >> UNIT_SHIFT) as u8)?,
            count_flags: ((word & COUNT_FLAGS_MASK) >> 10) as u8,
            values: values
                .chunks_exact(2)
                .map(|pair| ScanValue(u16::from_le_bytes([pair[0], pair[1]])))
                .collect(),
        })
    }

    /// Appends the data between the B0 code and the status byte.
    pub(crate) fn encode_data(&self, out: &mut Vec<u8>) -> Result<(), SickError> {
        if self.values.len() > MAX_SCAN_VALUES {
            return Err(SickError::TooManyValues {
                count: self.values.len(),
                max: MAX_SCAN_VALUES,
            });
        }
        let word = self.values.len() as u16
            | (u16::from(self.count_flags & 0x0F) << 10)
            | (u16::from(self.unit.scan_bits()) << UNIT_SHIFT);
        out.extend_from_slice(&word.to_le_bytes());
        for value in &self.values {
            out.extend_from_slice(&value.0.to_le_bytes());
        }
        Ok(())
    }
}

/// The scan's angular width.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScanWidth {
    /// 100 degrees, from -50 to +50.
    Deg100,
    /// 180 degrees, from -90 to +90.
    Deg180,
}

impl ScanWidth {
    /// The width in degrees.
    pub fn degrees(self) -> u16 {
        match self {
            Self::Deg100 => 100,
            Self::Deg180 => 180,
        }
    }
}

/// The angle between values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AngularResolution {
    /// 1 degree.
    OneDegree,
    /// 0.5 degree.
    HalfDegree,
    /// 0.25 degree (100 degree scans only).
    QuarterDegree,
}

impl AngularResolution {
    /// The resolution in hundredths of a degree, as the `3B` command sends it.
    pub fn centidegrees(self) -> u16 {
        match self {
            Self::OneDegree => 100,
            Self::HalfDegree => 50,
            Self::QuarterDegree => 25,
        }
    }

    /// Mirror turns per complete scan: finer resolutions interlace several turns, which is
    /// why a 0.5 degree scan comes at half the mirror's rate.
    pub fn turns_per_scan(self) -> u32 {
        match self {
            Self::OneDegree => 1,
            Self::HalfDegree => 2,
            Self::QuarterDegree => 4,
        }
    }
}

/// The angles of a scan's values: width and resolution, as set by the `3B` command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScanLayout {
    /// The angular width.
    pub width: ScanWidth,
    /// The angle between values.
    pub resolution: AngularResolution,
}

impl ScanLayout {
    /// 180 degrees at 0.5 degree: 361 values.
    pub const WIDE_HALF_DEGREE: Self = Self {
        width: ScanWidth::Deg180,
        resolution: AngularResolution::HalfDegree,
    };

    /// Every layout the scanners offer (180 degrees at 0.25 would not fit a telegram).
    pub const ALL: [Self; 5] = [
        Self::WIDE_HALF_DEGREE,
        Self {
            width: ScanWidth::Deg180,
            resolution: AngularResolution::OneDegree,
        },
        Self {
            width: ScanWidth::Deg100,
            resolution: AngularResolution::OneDegree,
        },
        Self {
            width: ScanWidth::Deg100,
            resolution: AngularResolution::HalfDegree,
        },
        Self {
            width: ScanWidth::Deg100,
            resolution: AngularResolution::QuarterDegree,
        },
    ];

    /// The layout of the `3B` command's raw fields (degrees, hundredths of a degree).
    pub fn from_raw(width_deg: u16, resolution_cdeg: u16) -> Result<Self, SickError> {
        Self::ALL
            .into_iter()
            .find(|layout| {
                layout.width.degrees() == width_deg
                    && layout.resolution.centidegrees() == resolution_cdeg
            })
            .ok_or(SickError::UnsupportedLayout {
                width_deg,
                resolution_cdeg,
            })
    }

    /// The layout whose scans have `count` values, if exactly one has.
    pub fn from_value_count(count: usize) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|layout| layout.value_count() == count)
    }

    /// Values per scan: 361 for 180 degrees at 0.5, 181 at 1.
    pub fn value_count(self) -> usize {
        usize::from(self.width.degrees() * 100 / self.resolution.centidegrees()) + 1
    }

    /// The angle of the first value: minus half the width.
    pub fn start_rad(self) -> f64 {
        -f64::from(self.width.degrees()).to_radians() / 2.0
    }

    /// The angle between values.
    pub fn step_rad(self) -> f64 {
        (f64::from(self.resolution.centidegrees()) / 100.0).to_radians()
    }

    /// The angle of value `index` in the scanner's frame, 0 straight ahead, counter-clockwise
    /// positive.
    pub fn angle_rad(self, index: usize) -> f64 {
        self.start_rad() + index as f64 * self.step_rad()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn count_unit_and_flags_are_decoded_from_the_count_word() {
        // 2 values, mm (bits 14-15 = 01), count flags 0b0101.
        let word: u16 = 2 | (0b0101 << 10) | (1 << 14);
        let mut data = word.to_le_bytes().to_vec();
        data.extend_from_slice(&(0xE000u16 | 1234).to_le_bytes());
        data.extend_from_slice(&8191u16.to_le_bytes());
        let scan = Scan::decode_data(&data).unwrap();
        assert_eq!(scan.unit, RangeUnit::Millimetre);
        assert_eq!(scan.count_flags, 0b0101);
        assert_eq!(scan.values[0].range(), 1234);
        assert_eq!(scan.values[0].flags(), 0b111);
        assert_eq!(scan.ranges_m(), vec![1.234, 8.191]);
    }

    #[test]
    fn a_count_that_disagrees_with_the_values_is_an_error() {
        let data = [3, 0, 1, 0];
        assert_eq!(
            Scan::decode_data(&data),
            Err(SickError::ScanCountMismatch {
                declared: 3,
                actual: 1
            })
        );
    }

    #[test]
    fn unit_bits_eleven_are_an_error() {
        assert_eq!(
            Scan::decode_data(&[0, 0xC0]),
            Err(SickError::UnknownUnit { code: 3 })
        );
    }

    #[test]
    fn half_degree_scans_have_361_values_from_minus_to_plus_90_degrees() {
        let layout = ScanLayout::WIDE_HALF_DEGREE;
        assert_eq!(layout.value_count(), 361);
        assert!((layout.angle_rad(0) + 90f64.to_radians()).abs() < 1e-12);
        assert!(layout.angle_rad(180).abs() < 1e-12);
        assert!((layout.angle_rad(360) - 90f64.to_radians()).abs() < 1e-12);
        let one_degree = ScanLayout::from_raw(180, 100).unwrap();
        assert_eq!(one_degree.value_count(), 181);
        assert_eq!(ScanLayout::from_value_count(181), Some(one_degree));
        assert_eq!(
            ScanLayout::from_value_count(401).map(|l| l.width),
            Some(ScanWidth::Deg100)
        );
    }

    #[test]
    fn every_offered_layout_fits_one_telegram() {
        for layout in ScanLayout::ALL {
            assert!(layout.value_count() <= MAX_SCAN_VALUES, "{layout:?}");
        }
        assert_eq!(
            ScanLayout::from_raw(180, 25),
            Err(SickError::UnsupportedLayout {
                width_deg: 180,
                resolution_cdeg: 25
            })
        );
    }
}
