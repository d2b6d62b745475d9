//! Grayscale H.264 through OpenH264 (native only). Each stream is coded as
//! its own video: the samples are the luma plane, chroma is a constant 128.
//! The encoder is driven through the raw OpenH264 API, because the openh264
//! crate's configuration clamps QP to 12 and has no switch for CABAC. One
//! access unit (Annex-B NAL units with start codes) comes out per frame.

use crate::error::{Error, Result};
use openh264_sys2 as sys;
use std::ptr::null_mut;

/// How a stream is coded.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VideoSettings {
    /// Constant quantization parameter 0..=51 (lower is finer); used when
    /// `kbps` is absent.
    pub qp: u8,
    /// Target bitrate of this stream in kbit/s at `fps`, instead of a constant QP.
    pub kbps: Option<f32>,
    /// With `kbps`: let the rate control use only QPs `qp..=qp_max` (by
    /// default it may use 0..=51). `cgv eval` brackets two adjacent QPs
    /// this way to hit a file size between them.
    pub qp_max: Option<u8>,
    /// Frames between intra (IDR) frames.
    pub gop: u32,
    /// CABAC entropy coding (else CAVLC).
    pub cabac: bool,
    pub fps: f32,
}

impl VideoSettings {
    /// Checks the settings H.264 can take, naming the one that is off.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.qp > 51 {
            return Err(format!("QP {} is not in 0..=51", self.qp));
        }
        if let Some(k) = self.kbps {
            if !(k.is_finite() && k > 0.0) {
                return Err(format!("a bitrate of {k} kbit/s is not above 0"));
            }
        }
        if self.qp_max.is_some_and(|m| m > 51 || m < self.qp) {
            return Err(format!("the highest QP {:?} is not in {}..=51", self.qp_max, self.qp));
        }
        if self.gop == 0 {
            return Err("the GOP (frames between intra frames) must be at least 1".into());
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return Err(format!("frame rate {} is not above 0", self.fps));
        }
        Ok(())
    }
}

impl Default for VideoSettings {
    fn default() -> Self {
        VideoSettings { qp: 20, kbps: None, qp_max: None, gop: 30, cabac: true, fps: 30.0 }
    }
}

fn check(rc: i32, what: &str) -> Result<()> {
    if rc == 0 {
        Ok(())
    } else {
        Err(Error::Video(format!("OpenH264 {what} failed with code {rc}")))
    }
}

/// An H.264 encoder for one grayscale stream.
pub struct Encoder {
    enc: *mut sys::ISVCEncoder,
    width: usize,
    height: usize,
    chroma: Vec<u8>,
}

// The encoder is used by one thread at a time; OpenH264 keeps no thread-local state.
unsafe impl Send for Encoder {}

impl Encoder {
    pub fn new(width: usize, height: usize, s: &VideoSettings) -> Result<Encoder> {
        if width < 16 || height < 16 || width % 2 != 0 || height % 2 != 0 || width > 3840 || height > 2160 {
            return Err(Error::Argument(format!(
                "H.264 frames must be even, 16x16 to 3840x2160 (got {width}x{height})"
            )));
        }
        s.validate().map_err(Error::Argument)?;
        let mut enc: *mut sys::ISVCEncoder = null_mut();
        // SAFETY: plain FFI calls following OpenH264's documented sequence:
        // create, GetDefaultParams, InitializeExt; the vtable comes from the library.
        unsafe {
            check(sys::source::APILoader::WelsCreateSVCEncoder(&mut enc), "encoder creation")?;
            if enc.is_null() {
                return Err(Error::Video("OpenH264 returned no encoder".into()));
            }
            let vt = &**enc;
            // Errors come back as return codes; keep OpenH264's own log quiet.
            if let Some(set_option) = vt.SetOption {
                let mut level: i32 = sys::WELS_LOG_QUIET;
                set_option(enc, sys::ENCODER_OPTION_TRACE_LEVEL, (&mut level as *mut i32).cast());
            }
            let mut p = sys::SEncParamExt::default();
            let get_default = vt.GetDefaultParams.ok_or_else(|| Error::Video("OpenH264 vtable incomplete".into()))?;
            check(get_default(enc, &mut p), "GetDefaultParams")?;
            p.iUsageType = sys::CAMERA_VIDEO_REAL_TIME;
            p.iPicWidth = width as i32;
            p.iPicHeight = height as i32;
            p.fMaxFrameRate = s.fps;
            p.iSpatialLayerNum = 1;
            p.iTemporalLayerNum = 1;
            p.uiIntraPeriod = s.gop.max(1);
            p.iNumRefFrame = 1;
            p.iEntropyCodingModeFlag = s.cabac as i32;
            p.bEnableFrameSkip = false;
            p.bEnableDenoise = false;
            p.bEnableBackgroundDetection = false;
            p.bEnableAdaptiveQuant = false;
            p.bEnableSceneChangeDetect = false;
            p.bEnableLongTermReference = false;
            p.iMultipleThreadIdc = 1;
            p.iLoopFilterDisableIdc = 0;
            p.eSpsPpsIdStrategy = sys::CONSTANT_ID;
            let bps = match s.kbps {
                Some(k) => {
                    p.iRCMode = sys::RC_BITRATE_MODE;
                    (p.iMinQp, p.iMaxQp) = match s.qp_max {
                        Some(m) => (s.qp as i32, m.clamp(s.qp, 51) as i32),
                        None => (0, 51),
                    };
                    (k * 1000.0).clamp(1000.0, 2.5e8) as i32
                }
                None => {
                    // Constant QP: quality mode pinned to one QP, a bitrate too
                    // high to bind, and no adaptive quantization.
                    p.iRCMode = sys::RC_QUALITY_MODE;
                    p.iMinQp = s.qp as i32;
                    p.iMaxQp = s.qp as i32;
                    // Under the level-5.2 ceiling OpenH264 checks (288 Mbit/s).
                    250_000_000
                }
            };
            p.iTargetBitrate = bps;
            p.iMaxBitrate = sys::UNSPECIFIED_BIT_RATE as i32;
            let l = &mut p.sSpatialLayers[0];
            l.iVideoWidth = width as i32;
            l.iVideoHeight = height as i32;
            l.fFrameRate = s.fps;
            l.iSpatialBitrate = bps;
            l.iMaxSpatialBitrate = sys::UNSPECIFIED_BIT_RATE as i32;
            l.iDLayerQp = s.qp as i32;
            l.sSliceArgument.uiSliceMode = sys::SM_SINGLE_SLICE;
            l.sSliceArgument.uiSliceNum = 1;
            let init = vt.InitializeExt.ok_or_else(|| Error::Video("OpenH264 vtable incomplete".into()))?;
            if let Err(e) = check(init(enc, &p), "InitializeExt") {
                sys::source::APILoader::WelsDestroySVCEncoder(enc);
                return Err(e);
            }
        }
        Ok(Encoder { enc, width, height, chroma: vec![128; (width / 2) * (height / 2)] })
    }

    /// Encodes one frame of samples (row-major, `width * height`) and returns
    /// its access unit.
    pub fn encode(&mut self, luma: &[u8]) -> Result<Vec<u8>> {
        if luma.len() != self.width * self.height {
            return Err(Error::Argument(format!(
                "frame has {} samples, expected {}",
                luma.len(),
                self.width * self.height
            )));
        }
        let (w, h) = (self.width as i32, self.height as i32);
        let pic = sys::SSourcePicture {
            iColorFormat: sys::videoFormatI420,
            iStride: [w, w / 2, w / 2, 0],
            pData: [
                luma.as_ptr() as *mut u8,
                self.chroma.as_ptr() as *mut u8,
                self.chroma.as_ptr() as *mut u8,
                null_mut(),
            ],
            iPicWidth: w,
            iPicHeight: h,
            uiTimeStamp: 0,
            bPsnrY: false,
            bPsnrU: false,
            bPsnrV: false,
        };
        let mut info = sys::SFrameBSInfo::default();
        let mut out = Vec::new();
        // SAFETY: `pic` points at buffers of the declared sizes that outlive the
        // call; OpenH264 only reads them. The layer buffers it returns stay
        // valid until the next call, and we copy them out before that.
        unsafe {
            let vt = &**self.enc;
            let encode = vt.EncodeFrame.ok_or_else(|| Error::Video("OpenH264 vtable incomplete".into()))?;
            check(encode(self.enc, &pic, &mut info), "EncodeFrame")?;
            for l in 0..info.iLayerNum.clamp(0, 128) as usize {
                let layer = &info.sLayerInfo[l];
                let mut size = 0usize;
                for n in 0..layer.iNalCount.max(0) as usize {
                    size += *layer.pNalLengthInByte.add(n) as usize;
                }
                out.extend_from_slice(std::slice::from_raw_parts(layer.pBsBuf, size));
            }
        }
        if out.is_empty() {
            return Err(Error::Video("OpenH264 skipped a frame".into()));
        }
        Ok(out)
    }
}

impl Encoder {
    /// Makes the next picture an IDR picture (with its SPS and PPS), where a
    /// decoder can start: a random-access point.
    pub fn force_idr(&mut self) -> Result<()> {
        // SAFETY: `enc` is a live encoder; ForceIntraFrame only sets a flag.
        unsafe {
            let vt = &**self.enc;
            let force = vt.ForceIntraFrame.ok_or_else(|| Error::Video("OpenH264 vtable incomplete".into()))?;
            check(force(self.enc, true), "ForceIntraFrame")
        }
    }
}

impl Drop for Encoder {
    fn drop(&mut self) {
        // SAFETY: `enc` was created by WelsCreateSVCEncoder and is destroyed once.
        unsafe {
            let vt = &**self.enc;
            if let Some(uninit) = vt.Uninitialize {
                uninit(self.enc);
            }
            sys::source::APILoader::WelsDestroySVCEncoder(self.enc);
        }
    }
}

/// An H.264 decoder for one grayscale stream (OpenH264, bit-exact with any
/// conforming decoder such as the browser's).
pub struct Decoder {
    inner: openh264::decoder::Decoder,
}

impl Decoder {
    pub fn new() -> Result<Decoder> {
        Ok(Decoder {
            inner: openh264::decoder::Decoder::new().map_err(|e| Error::Video(format!("OpenH264 decoder: {e}")))?,
        })
    }

    /// Decodes one access unit into its luma samples (row-major, `width * height`).
    pub fn decode(&mut self, access_unit: &[u8], width: usize, height: usize) -> Result<Vec<u8>> {
        use openh264::formats::YUVSource;
        let yuv = self
            .inner
            .decode(access_unit)
            .map_err(|e| Error::Video(format!("H.264 decoding failed: {e}")))?
            .ok_or_else(|| Error::Video("H.264 access unit produced no picture".into()))?;
        let (w, h) = yuv.dimensions();
        if w != width || h != height {
            return Err(Error::Video(format!("decoded picture is {w}x{h}, expected {width}x{height}")));
        }
        let stride = yuv.strides().0;
        let y = yuv.y();
        let mut out = Vec::with_capacity(width * height);
        for r in 0..height {
            out.extend_from_slice(&y[r * stride..r * stride + width]);
        }
        Ok(out)
    }
}
