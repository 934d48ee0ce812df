//! `Map`: a grid layout from a reference model, a file or text, and the
//! map and cell arguments of the other classes.

use std::sync::Arc;

use buridan_env::{Cell, Map, MapSource, REFERENCE_MODELS};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use crate::errors::map_err;

/// A grid layout: walls, free cells and (for reference models and maps with
/// a `.scen` beside them) fixed starts and goals.
///
/// `Map("rm-2.1")` loads a bundled reference model, `Map("path/to.map")` a
/// MovingAI `.map` file (and the `.scen` of the same stem beside it),
/// `Map("maze/19x19/seed=0")` a generated map by its spec
/// (`buridan_env::generate`);
/// `Map.from_text(...)` parses text. Malformed text raises `MapError` whose
/// message names the file and line (`file:line: problem`).
#[pyclass(name = "Map", module = "buridan._buridan", frozen)]
pub struct PyMap {
    pub map: Arc<Map>,
}

#[pymethods]
impl PyMap {
    /// Loads a reference model id (`"rm-2.1"`), a MovingAI `.map` path or
    /// a generated map's spec (`"maze/19x19/seed=0"`).
    #[new]
    fn new(py: Python<'_>, id_or_path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let name = path_like(id_or_path)?;
        Ok(Self {
            map: Arc::new(Map::load(&name).map_err(|e| map_err(py, e))?),
        })
    }

    /// Parses MovingAI `.map` text (and optionally `.scen` text); errors name
    /// the map as `<name>.map` / `<name>.scen` with the line.
    #[staticmethod]
    #[pyo3(signature = (map_text, scen_text=None, name="text"))]
    fn from_text(
        py: Python<'_>,
        map_text: String,
        scen_text: Option<String>,
        name: &str,
    ) -> PyResult<Self> {
        let source = MapSource {
            name: name.to_string(),
            map_text,
            scen_text,
        };
        Ok(Self {
            map: Arc::new(source.parse().map_err(|e| map_err(py, e))?),
        })
    }

    /// The map's name (reference model id or file stem).
    #[getter]
    fn name(&self) -> &str {
        &self.map.name
    }

    /// Rows of the grid.
    #[getter]
    fn height(&self) -> usize {
        self.map.grid.height()
    }

    /// Columns of the grid.
    #[getter]
    fn width(&self) -> usize {
        self.map.grid.width()
    }

    /// Walls as a `(height, width)` bool array (a copy).
    #[getter]
    fn walls<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<bool>> {
        let g = &self.map.grid;
        Array2::from_shape_vec((g.height(), g.width()), g.walls().to_vec())
            .expect("walls are height x width")
            .into_pyarray(py)
    }

    /// Free cells as `(row, col)` tuples, row-major.
    #[getter]
    fn free_cells(&self) -> Vec<(usize, usize)> {
        cells(self.map.grid.free_cells())
    }

    /// The fixed scenario as `(starts, goals)` lists of `(row, col)`, or `None`.
    #[getter]
    fn scenario(&self) -> Option<(Cells, Cells)> {
        self.map
            .scenario
            .as_ref()
            .map(|s| (cells(&s.starts), cells(&s.goals)))
    }

    /// Shortest-path distances (steps) from every cell to `(row, col)` on
    /// the static layout, `(height, width)` uint16; 65535 = unreachable.
    fn distances_to<'py>(
        &self,
        py: Python<'py>,
        row: usize,
        col: usize,
    ) -> PyResult<Bound<'py, PyArray2<u16>>> {
        let g = &self.map.grid;
        let target = Cell::new(row, col);
        if !g.contains(target) {
            return Err(PyValueError::new_err(format!(
                "({row}, {col}) is outside the {}x{} grid",
                g.height(),
                g.width()
            )));
        }
        Ok(
            Array2::from_shape_vec((g.height(), g.width()), g.distances_to(target).to_vec())
                .expect("one distance per cell")
                .into_pyarray(py),
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "Map('{}', {}x{}, {} free cells{})",
            self.map.name,
            self.map.grid.height(),
            self.map.grid.width(),
            self.map.grid.free_cells().len(),
            match &self.map.scenario {
                Some(s) => format!(", fixed scenario of {} agents", s.starts.len()),
                None => String::new(),
            }
        )
    }
}

/// The bundled reference models as `(id, description)` pairs.
#[pyfunction]
pub fn reference_models() -> Vec<(&'static str, &'static str)> {
    REFERENCE_MODELS
        .iter()
        .map(|m| (m.id, m.description))
        .collect()
}

/// Cells as `(row, col)` tuples.
pub type Cells = Vec<(usize, usize)>;

/// `cells` as `(row, col)` tuples.
pub fn cells(cells: &[Cell]) -> Cells {
    cells.iter().map(|c| (c.row, c.col)).collect()
}

/// A `str` or `os.PathLike` argument as text.
fn path_like(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(s) = obj.extract::<String>() {
        return Ok(s);
    }
    match obj.extract::<std::path::PathBuf>() {
        Ok(p) => Ok(p.to_string_lossy().into_owned()),
        Err(_) => Err(PyTypeError::new_err(format!(
            "expected a map id, a path or a buridan.Map, got {}",
            obj.get_type().name()?
        ))),
    }
}

/// A map argument: a `Map`, a reference model id or a path.
pub fn map_arg(obj: &Bound<'_, PyAny>) -> PyResult<Arc<Map>> {
    if let Ok(m) = obj.extract::<PyRef<'_, PyMap>>() {
        return Ok(m.map.clone());
    }
    let name = path_like(obj)?;
    Map::load(&name)
        .map(Arc::new)
        .map_err(|e| map_err(obj.py(), e))
}
