//! A texture's mean colour, the one reflectance a radiosity polygon can take from it.
//!
//! How it works: texels are sRGB-encoded (glTF `baseColorTexture` by the
//! specification, OBJ `map_Kd` by practice); each is decoded to linear with the sRGB
//! transfer function and the linear values are averaged, channel by channel (alpha is
//! ignored, a grey texture counts for all three channels). The loaders multiply the
//! mean by the material's factor (`baseColorFactor`, `Kd`). Files are read with the
//! `image` crate, PNG and JPEG only.
//!
//! It does not map texture coordinates: a polygon takes the texture's mean over the
//! whole image, not over the part its coordinates cover.

use std::path::Path;

/// sRGB-encoded `[0, 1]` value → linear (IEC 61966-2-1).
pub(crate) fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Mean linear RGB of sRGB texels given as `channels` values per texel, each
/// `value / max` in `[0, 1]`. `None` for an empty image or 0 channels.
pub(crate) fn mean_linear(
    values: impl ExactSizeIterator<Item = f64>,
    channels: usize,
) -> Option<[f64; 3]> {
    if channels == 0 || values.len() < channels {
        return None;
    }
    // One lookup per 8-bit level would be faster; textures are small next to a solve.
    let mut sum = [0.0f64; 3];
    let mut count = 0usize;
    let mut texel = [0.0f64; 4];
    for (k, v) in values.enumerate() {
        texel[k % channels] = v;
        if k % channels == channels - 1 {
            let rgb = if channels < 3 {
                [texel[0]; 3]
            } else {
                [texel[0], texel[1], texel[2]]
            };
            for c in 0..3 {
                sum[c] += srgb_to_linear(rgb[c].clamp(0.0, 1.0));
            }
            count += 1;
        }
    }
    (count > 0).then(|| sum.map(|s| s / count as f64))
}

/// Mean linear RGB of the PNG or JPEG file at `path`; `Err` says why it could not be
/// read.
pub(crate) fn mean_of_file(path: &Path) -> std::result::Result<[f64; 3], String> {
    let img = image::ImageReader::open(path)
        .map_err(|e| e.to_string())?
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    mean_of_image(&img)
}

fn mean_of_image(img: &image::DynamicImage) -> std::result::Result<[f64; 3], String> {
    let rgb = img.to_rgb32f();
    mean_linear(rgb.as_raw().iter().map(|&v| f64::from(v)), 3)
        .ok_or_else(|| "an empty image".to_string())
}

/// The material line the loaders print: `material "wood": reflectance = mean of
/// floor.png [..] x factor [..] = [..]`.
pub(crate) fn note(material: &str, source: &str, mean: [f64; 3], factor: [f64; 3]) -> String {
    let rho: [f64; 3] = std::array::from_fn(|c| mean[c] * factor[c]);
    format!(
        "material \"{material}\": reflectance = mean colour of texture {source} (linear) {} x factor {} = {}",
        fmt(mean),
        fmt(factor),
        fmt(rho)
    )
}

/// `[r, g, b]` to 4 decimals, for messages.
pub(crate) fn fmt(v: [f64; 3]) -> String {
    format!("[{:.4}, {:.4}, {:.4}]", v[0], v[1], v[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_mid_grey_is_a_fifth_linear() {
        // sRGB 128/255 = 0.50196 → linear 0.21586 (the usual table value).
        assert!((srgb_to_linear(128.0 / 255.0) - 0.21586).abs() < 1e-4);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn mean_is_taken_in_linear_space() {
        // Half black, half white texels: linear mean 0.5, not the sRGB mean 0.5 → 0.214.
        let texels = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let m = mean_linear(texels.into_iter(), 3).unwrap();
        assert!((m[0] - 0.5).abs() < 1e-12, "{m:?}");
        let grey = mean_linear([1.0, 0.0].into_iter(), 1).unwrap();
        assert_eq!(grey, [0.5; 3]);
        assert_eq!(mean_linear([].into_iter(), 3), None);
    }
}
