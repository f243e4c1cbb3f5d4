//! Bindings of the `lfd-mcap` recording reader: `read_recording` (a whole, possibly damaged,
//! recording with its tracks decoded into numpy arrays) and `read_summary` (a finished
//! recording's summary section). Both read with the interpreter released; a read error is an
//! `lfd.errors.RecordingFormatError` with the reader's one-line text.

use std::path::PathBuf;

use lfd_mcap::{ChannelSummary, Damage, MetadataMap, Options, RawMessages};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};

use crate::errors::{guard, recording_format};

fn metadata_dict<'py>(py: Python<'py>, items: &[(String, String)]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in items {
        d.set_item(k, v)?;
    }
    Ok(d)
}

fn metadata_records<'py>(py: Python<'py>, map: &MetadataMap) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, items) in map {
        d.set_item(name, metadata_dict(py, items)?)?;
    }
    Ok(d)
}

fn channels<'py>(py: Python<'py>, channels: &[ChannelSummary]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for c in channels {
        let d = PyDict::new(py);
        d.set_item("topic", &c.topic)?;
        d.set_item("schema", &c.schema)?;
        d.set_item("schema_encoding", &c.schema_encoding)?;
        d.set_item("schema_data", PyBytes::new(py, &c.schema_data))?;
        d.set_item("encoding", &c.encoding)?;
        d.set_item("metadata", metadata_dict(py, &c.metadata)?)?;
        d.set_item("count", c.count)?;
        d.set_item("first_ns", c.first_ns)?;
        d.set_item("last_ns", c.last_ns)?;
        list.append(d)?;
    }
    Ok(list)
}

fn raw_dict<'py>(py: Python<'py>, raw: &[(String, RawMessages)]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (topic, messages) in raw {
        let items = messages
            .iter()
            .map(|(t, data)| {
                PyTuple::new(
                    py,
                    [
                        t.into_pyobject(py)?.into_any(),
                        PyBytes::new(py, data).into_any(),
                    ],
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        d.set_item(topic, PyList::new(py, items)?)?;
    }
    Ok(d)
}

/// The damaged regions: `offset`, `end`, `chunks` (ordinals or None), `messages` (or None),
/// `why`.
fn damage<'py>(py: Python<'py>, damage: &[Damage]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for d in damage {
        let item = PyDict::new(py);
        item.set_item("offset", d.offset)?;
        item.set_item("end", d.end)?;
        item.set_item("chunks", d.chunks.clone())?;
        item.set_item("messages", d.messages)?;
        item.set_item("why", &d.why)?;
        list.append(item)?;
    }
    Ok(list)
}

/// A flat vector as a numpy array of `shape` (no copy: numpy takes the vector).
fn array<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let a = PyArray1::from_vec(py, v);
    Ok(if shape.len() == 1 {
        a.into_any()
    } else {
        a.reshape(shape.to_vec())?.into_any()
    })
}

/// Read a whole recording (see `lfd._hmmseg.read_recording` in `python/lfd/_hmmseg.pyi`).
#[pyfunction]
#[pyo3(signature = (path, images = true, raw_topics = None, raw_limit = None))]
fn read_recording(
    py: Python<'_>,
    path: PathBuf,
    images: bool,
    raw_topics: Option<Vec<String>>,
    raw_limit: Option<u64>,
) -> PyResult<Bound<'_, PyDict>> {
    guard(py, || {
        let options = Options {
            images,
            raw_topics,
            raw_limit,
        };
        let rec = py
            .detach(|| lfd_mcap::read_recording(&path, &options))
            .map_err(|e| recording_format(py, e.0))?;
        let out = PyDict::new(py);
        out.set_item("library", &rec.library)?;
        out.set_item("file_size", rec.file_size)?;
        out.set_item("complete", rec.complete)?;
        out.set_item("error", &rec.error)?;
        out.set_item("damage", damage(py, &rec.damage)?)?;
        out.set_item("chunks", rec.chunks)?;
        out.set_item("raw_truncated", rec.raw_truncated)?;
        out.set_item("channels", channels(py, &rec.channels)?)?;
        out.set_item("metadata", metadata_records(py, &rec.metadata)?)?;
        out.set_item("raw", raw_dict(py, &rec.raw)?)?;
        let hands = PyDict::new(py);
        for (topic, h) in rec.hands {
            let n = h.t_ns.len();
            let d = PyDict::new(py);
            d.set_item("t_ns", array(py, h.t_ns, &[n])?)?;
            d.set_item("keypoints", array(py, h.keypoints, &[n, 21, 3])?)?;
            d.set_item("bad", h.bad)?;
            hands.set_item(topic, d)?;
        }
        out.set_item("hands", hands)?;
        let confidence = PyDict::new(py);
        for (topic, c) in rec.confidence {
            let m = c.t_ns.len();
            let d = PyDict::new(py);
            d.set_item("t_ns", array(py, c.t_ns, &[m])?)?;
            d.set_item("confidence", array(py, c.confidence, &[m, 21])?)?;
            d.set_item("visible", array(py, c.visible, &[m, 21])?)?;
            d.set_item("has_visible", array(py, c.has_visible, &[m])?)?;
            d.set_item("bad", c.bad)?;
            confidence.set_item(topic, d)?;
        }
        out.set_item("confidence", confidence)?;
        let poses = PyDict::new(py);
        for (topic, p) in rec.poses {
            let n = p.t_ns.len();
            let d = PyDict::new(py);
            d.set_item("t_ns", array(py, p.t_ns, &[n])?)?;
            d.set_item("position", array(py, p.position, &[n, 3])?)?;
            d.set_item("quaternion", array(py, p.quaternion, &[n, 4])?)?;
            d.set_item("bad", p.bad)?;
            poses.set_item(topic, d)?;
        }
        out.set_item("poses", poses)?;
        Ok(out)
    })
}

/// Read a finished recording's summary section (see `python/lfd/_hmmseg.pyi`).
#[pyfunction]
#[pyo3(signature = (path, topics = Vec::new()))]
fn read_summary(
    py: Python<'_>,
    path: PathBuf,
    topics: Vec<String>,
) -> PyResult<Option<Bound<'_, PyDict>>> {
    guard(py, || {
        let Some(s) = py
            .detach(|| lfd_mcap::read_summary(&path, &topics))
            .map_err(|e| recording_format(py, e.0))?
        else {
            return Ok(None);
        };
        let out = PyDict::new(py);
        out.set_item("library", &s.library)?;
        out.set_item("file_size", s.file_size)?;
        out.set_item("channels", channels(py, &s.channels)?)?;
        out.set_item("metadata", metadata_records(py, &s.metadata)?)?;
        let attachments = PyList::empty(py);
        for a in &s.attachments {
            let d = PyDict::new(py);
            d.set_item("name", &a.name)?;
            d.set_item("media_type", &a.media_type)?;
            d.set_item("log_time", a.log_time)?;
            d.set_item("size", a.size)?;
            attachments.append(d)?;
        }
        out.set_item("attachments", attachments)?;
        out.set_item("messages", s.messages)?;
        out.set_item("chunks", s.chunks)?;
        out.set_item("raw_truncated", s.raw_truncated)?;
        out.set_item("damage", damage(py, &s.damage)?)?;
        out.set_item("raw", raw_dict(py, &s.raw)?)?;
        Ok(Some(out))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_recording, m)?)?;
    m.add_function(wrap_pyfunction!(read_summary, m)?)?;
    Ok(())
}
