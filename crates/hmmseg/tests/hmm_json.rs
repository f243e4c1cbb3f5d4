//! JSON round trip and every JSON error.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::random_model;
use hmmseg::hmm::{CovarianceType, Hmm};
use hmmseg::EngineError;

#[test]
fn round_trip_is_bit_identical() {
    for (cov, m, f, lr) in [
        (CovarianceType::Diag, 1, 1, true),
        (CovarianceType::Full, 1, 3, false),
        (CovarianceType::Diag, 3, 2, false),
        (CovarianceType::Full, 2, 4, true),
    ] {
        let model = random_model(5, m, f, cov, lr, 21);
        let json = model.to_json().unwrap();
        assert!(json.contains("\"format_version\":1"));
        let back = Hmm::from_json(&json).unwrap();
        assert_eq!(back, model);
        assert_eq!(back.to_json().unwrap(), json);
        let bits = |h: &Hmm| -> Vec<u64> {
            let mut v: Vec<u64> = h
                .startprob()
                .iter()
                .chain(h.transmat().iter())
                .chain(h.weights().iter())
                .map(|x| x.to_bits())
                .collect();
            for (mu, cs) in h.means().iter().zip(h.covars()) {
                v.extend(mu.iter().map(|x| x.to_bits()));
                for c in cs {
                    v.extend(c.iter().map(|x| x.to_bits()));
                }
            }
            v
        };
        assert_eq!(bits(&back), bits(&model));
        // Serde (e.g. a model embedded in a larger document) goes through the same path.
        let via_serde: Hmm = serde_json::from_str(&serde_json::to_string(&model).unwrap()).unwrap();
        assert_eq!(via_serde, model);
    }
}

#[test]
fn json_errors() {
    let model = random_model(2, 1, 1, CovarianceType::Diag, false, 1);
    let json = model.to_json().unwrap();
    let format = |s: &str| matches!(Hmm::from_json(s), Err(EngineError::Format(_)));
    assert!(format("not json"));
    assert!(format(&json[..json.len() / 2]));
    assert!(format("{}"));
    assert!(format(
        &json.replace("\"format_version\":1", "\"format_version\":2")
    ));
    assert!(format(
        &json.replace("\"format_version\":1", "\"format_version\":\"1\"")
    ));
    assert!(format(
        &json.replace("\"covariance\":\"diag\"", "\"covariance\":\"tied\"")
    ));
    assert!(format(&json.replacen('{', "{\"extra\":0,", 1)));
    // Well-formed JSON with invalid parameters: the validation error of from_params.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["startprob"] = serde_json::json!([0.9, 0.9]);
    assert!(matches!(
        Hmm::from_json(&v.to_string()),
        Err(EngineError::NotStochastic(_))
    ));
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["covars"][0][0][0][0] = serde_json::json!(-1.0);
    assert!(matches!(
        Hmm::from_json(&v.to_string()),
        Err(EngineError::NotPositiveDefinite(_))
    ));
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["transmat"][1] = serde_json::json!([1.0]);
    assert!(matches!(
        Hmm::from_json(&v.to_string()),
        Err(EngineError::ShapeMismatch(_))
    ));
}
