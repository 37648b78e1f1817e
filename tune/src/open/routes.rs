//! The tuning page's HTTP endpoints: the page, JSON for the state, the frames' blobs, the
//! plots and the ranges, PNG for the frame with its overlay.
//!
//! - `GET /`: the page.
//! - `GET /api/state`: the frames held, the classes and their ranges.
//! - `GET /api/frame/N`: frame N's blobs (and signs, with `--signs`); `GET /frame/N.png`:
//!   frame N drawn.
//! - `GET /api/plots`: per class, blobs and largest area per frame over the recording.
//! - `POST /api/ranges` `{class, y, u, v}`: sets a class's ranges.
//! - `POST /api/mark` `{frame, class, rect: [x, y, w, h], outside}`: marks pixels and
//!   refits the class; answers the YUV values marked.
//! - `POST /api/save`: writes the colour file.
//! - `POST /api/box` `{frame, class, box: [left, top, right, bottom]}` (full-frame px):
//!   labels an object on frame N; `POST /api/box/remove` `{frame, index}`: removes one;
//!   both answer the frame's boxes and the labelled frames.
//! - `POST /api/labels/save`: writes the labels file.
//! - `GET /api/score`: precision and recall per labelled class with the ranges as they
//!   are now, over the labelled frames held.

use std::sync::{Arc, Mutex};

use lewis_pages::axum::Router;
use lewis_pages::axum::body::Bytes;
use lewis_pages::axum::extract::DefaultBodyLimit;
use lewis_pages::axum::http::{Method, Uri};
use lewis_pages::axum::response::{IntoResponse, Response};
use lewis_perception::sweep;
use serde::Deserialize;
use serde_json::json;

use super::render;
use super::state::{State, lock};

const PAGE: &str = include_str!("page.html");

/// The largest request body taken (a mark or ranges are a few dozen bytes).
const MAX_BODY: usize = 64 * 1024;

/// One answer of the page's server: its status, content type and bytes.
struct Reply {
    status: u16,
    content_type: &'static str,
    body: Vec<u8>,
}

impl IntoResponse for Reply {
    fn into_response(self) -> Response {
        lewis_pages::respond(self.status, self.content_type, self.body)
    }
}

/// The page's routes over `state`. Every answer is computed on the blocking pool: a sweep
/// over the recording or a frame drawn takes a while, and holds the state's lock.
pub fn router(state: Arc<Mutex<State>>) -> Router {
    Router::new()
        .fallback(move |method: Method, uri: Uri, body: Bytes| {
            let state = Arc::clone(&state);
            async move {
                lewis_pages::blocking(move || answer(&method, uri.path(), &body, &state))
                    .await
                    .unwrap_or_else(|| text(500, "the answer failed: see the terminal"))
            }
        })
        .layer(DefaultBodyLimit::max(MAX_BODY))
}

#[derive(Deserialize)]
struct Ranges {
    class: usize,
    y: [u8; 2],
    u: [u8; 2],
    v: [u8; 2],
}

#[derive(Deserialize)]
struct Mark {
    frame: usize,
    class: usize,
    rect: [u32; 4],
    #[serde(default)]
    outside: bool,
}

#[derive(Deserialize)]
struct NewBox {
    frame: usize,
    class: usize,
    #[serde(rename = "box")]
    bounds: [u32; 4],
}

#[derive(Deserialize)]
struct RemoveBox {
    frame: usize,
    index: usize,
}

/// Answers one request.
fn answer(method: &Method, path: &str, request: &[u8], state: &Mutex<State>) -> Reply {
    match (method, path) {
        (&Method::GET, "/" | "/index.html") => {
            bytes(200, PAGE.as_bytes(), "text/html; charset=utf-8")
        }
        (&Method::GET, "/api/state") => state_json(&lock(state)),
        (&Method::GET, "/api/plots") => {
            let plots = lock(state).plots();
            json_response(200, &json!(plots))
        }
        (&Method::GET, p) if p.starts_with("/api/frame/") => {
            frame_json(&lock(state), p.trim_start_matches("/api/frame/"))
        }
        (&Method::GET, p) if p.starts_with("/frame/") && p.ends_with(".png") => frame_png(
            &lock(state),
            p.trim_start_matches("/frame/").trim_end_matches(".png"),
        ),
        (&Method::POST, "/api/ranges") => match body::<Ranges>(request) {
            Ok(r) => {
                let mut state = lock(state);
                match state.set_ranges(r.class, [r.y, r.u, r.v]) {
                    Ok(()) => state_json(&state),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (&Method::POST, "/api/mark") => match body::<Mark>(request) {
            Ok(m) => {
                let mut state = lock(state);
                match state.mark(m.frame, m.class, m.rect, m.outside) {
                    Ok(marked) => json_response(
                        200,
                        &json!({ "marked": marked, "classes": state.classes() }),
                    ),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (&Method::POST, "/api/save") => save(&lock(state)),
        (&Method::POST, "/api/box") => match body::<NewBox>(request) {
            Ok(b) => {
                let mut state = lock(state);
                match state.add_box(b.frame, b.class, b.bounds) {
                    Ok(()) => boxes_json(&state, b.frame),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (&Method::POST, "/api/box/remove") => match body::<RemoveBox>(request) {
            Ok(r) => {
                let mut state = lock(state);
                match state.remove_box(r.frame, r.index) {
                    Ok(()) => boxes_json(&state, r.frame),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (&Method::POST, "/api/labels/save") => save_labels(&mut lock(state)),
        (&Method::GET, "/api/score") => match lock(state).score() {
            Ok(score) => json_response(200, &json!(score)),
            Err(e) => text(500, &format!("{e:#}")),
        },
        (&Method::GET, _) => text(404, "no such page: try /"),
        _ => text(405, "method not allowed"),
    }
}

fn body<T: serde::de::DeserializeOwned>(request: &[u8]) -> Result<T, String> {
    serde_json::from_slice(request).map_err(|e| format!("bad request body: {e}"))
}

fn state_json(state: &State) -> Reply {
    let frames: Vec<_> = state
        .store
        .frames()
        .iter()
        .map(|f| {
            json!({
                "name": f.name,
                "width": f.width_px,
                "height": f.height_px,
                "full": state.full_size(f),
            })
        })
        .collect();
    json_response(
        200,
        &json!({
            "source": state.source,
            "colors": state.colors_path.display().to_string(),
            "save": state.save_path.display().to_string(),
            "loading": state.loading,
            "load_error": state.load_error,
            "stride": state.store.stride(),
            "offered": state.store.offered(),
            "frames": frames,
            "classes": state.classes(),
            "labels": labels_json(state),
        }),
    )
}

/// The labels file and which held frames are labelled.
fn labels_json(state: &State) -> serde_json::Value {
    let (labelled, not_held) = state.labelled_frames();
    json!({
        "path": state.labels_path.display().to_string(),
        "changed": state.labels_changed,
        "labelled": labelled,
        "not_held": not_held,
    })
}

fn boxes_json(state: &State, frame: usize) -> Reply {
    json_response(
        200,
        &json!({ "boxes": state.boxes(frame), "labels": labels_json(state) }),
    )
}

fn save_labels(state: &mut State) -> Reply {
    match state.save_labels() {
        Ok(objects) => json_response(
            200,
            &json!({
                "path": state.labels_path.display().to_string(),
                "frames": state.labels.frames.len(),
                "objects": objects,
                "labels": labels_json(state),
            }),
        ),
        Err(e) => text(500, &format!("{e:#}")),
    }
}

fn frame_index(state: &State, index: &str) -> Result<usize, Reply> {
    let index: usize = index
        .parse()
        .map_err(|_| text(400, "a frame is named by its number"))?;
    if index >= state.store.frames().len() {
        return Err(text(404, &format!("no frame {index} (yet)")));
    }
    Ok(index)
}

fn frame_json(state: &State, index: &str) -> Reply {
    let index = match frame_index(state, index) {
        Ok(i) => i,
        Err(response) => return response,
    };
    let Some(frame) = state.store.frames().get(index) else {
        return text(404, "no such frame");
    };
    match sweep::regions(&state.config, frame) {
        Ok(regions) => {
            let blobs: Vec<_> = regions
                .iter()
                .map(|r| {
                    json!({
                        "class": r.color,
                        "area_px": r.area_px.saturating_mul(sweep::PIXELS_PER_HELD_PIXEL),
                        "box": [r.left_px, r.top_px, r.right_px, r.bottom_px],
                        "centroid": [r.centroid_x_px, r.centroid_y_px],
                    })
                })
                .collect();
            let signs =
                state
                    .signs
                    .then(|| match render::signs(&state.config, frame) {
                        Ok(signs) => json!(signs
                    .signs
                    .iter()
                    .map(|s| json!({
                        "arrow": s.arrow,
                        "confidence": s.confidence,
                        "box": [s.board.left, s.board.top, s.board.right, s.board.bottom],
                    }))
                    .collect::<Vec<_>>()),
                        Err(e) => json!({ "error": format!("{e:#}") }),
                    });
            json_response(
                200,
                &json!({
                    "name": frame.name,
                    "blobs": blobs,
                    "signs": signs,
                    "boxes": state.boxes(index),
                }),
            )
        }
        Err(e) => text(500, &e.to_string()),
    }
}

fn frame_png(state: &State, index: &str) -> Reply {
    let index = match frame_index(state, index) {
        Ok(i) => i,
        Err(response) => return response,
    };
    let Some(frame) = state.store.frames().get(index) else {
        return text(404, "no such frame");
    };
    let drawn = sweep::regions(&state.config, frame)
        .map_err(anyhow::Error::from)
        .and_then(|regions| {
            // A sign the detector cannot look for (no White or Black class) is said in
            // the frame's JSON; the picture is drawn without boards.
            let boards = if state.signs {
                render::signs(&state.config, frame)
                    .map(|s| render::sign_boards(&s))
                    .unwrap_or_default()
            } else {
                Vec::new()
            };
            render::overlay_png(&state.config, frame, &regions, &boards)
        });
    match drawn {
        Ok(png) => bytes(200, &png, "image/png"),
        Err(e) => text(500, &format!("{e:#}")),
    }
}

fn save(state: &State) -> Reply {
    let text_out = state.colour_file();
    match std::fs::write(&state.save_path, &text_out) {
        Ok(()) => json_response(
            200,
            &json!({ "path": state.save_path.display().to_string(), "text": text_out }),
        ),
        Err(e) => text(
            500,
            &format!("cannot write {}: {e}", state.save_path.display()),
        ),
    }
}

fn bytes(status: u16, body: &[u8], content_type: &'static str) -> Reply {
    Reply {
        status,
        content_type,
        body: body.to_vec(),
    }
}

fn text(status: u16, message: &str) -> Reply {
    bytes(status, message.as_bytes(), "text/plain; charset=utf-8")
}

fn json_response(status: u16, value: &serde_json::Value) -> Reply {
    bytes(status, value.to_string().as_bytes(), "application/json")
}
