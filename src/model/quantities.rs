//! Named quantities that parameters are functions of, and the named sets of factors a model
//! offers to fit (model file `quantities:` and `factor_sets:`).
//!
//! A parameter written `value: "radius * cos(angle_a)"` is *derived*: it equals its
//! expression at the quantities' nominal values, and in a factor set that fits one of its
//! quantities it follows them. The quantities are what a factor set fits, in the terms of the
//! firmware or the datasheet they come from (a tower's radius and angle, one rod shared by
//! three legs); the model's own fit (its `identify` flags) is unchanged by them.

use super::params::Unit;

/// A named quantity (model file `quantities:`).
#[derive(Debug, Clone, PartialEq)]
pub struct Quantity {
    /// Its name, as expressions and factor sets write it.
    pub name: String,
    /// Its nominal value, SI units.
    pub nominal: f64,
    /// SI unit.
    pub unit: Unit,
    /// The standard deviation of what is known of it before any measurement, around
    /// `nominal` (model file `prior:`), SI units.
    pub prior: Option<f64>,
}

/// A named set of factors to fit together (model file `factor_sets:`): quantities, leg
/// parameters that are not derived, and instrument parameters; everything else is held at its
/// nominal value.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorSet {
    /// Its name (`klipper-6`, `rrf-7`, …).
    pub name: String,
    /// What it fits, by name.
    pub factors: Vec<String>,
    /// One line saying where it comes from, if the model says.
    pub note: Option<String>,
}

/// Keeps a model file's relations true after its parameters in `moved` took other values (a
/// calibrated model): a quantity used by a moved derived parameter no longer describes the
/// geometry, so it goes, with every expression that uses it (to a fixed point) and every factor
/// set that fits it; quantities no expression uses any more go too. The names of the factor
/// sets dropped.
pub fn drop_broken_relations(
    file: &mut crate::model::file::ModelFile,
    moved: &[&str],
) -> Vec<String> {
    let names: Vec<String> = file.quantities.iter().map(|q| q.name.clone()).collect();
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let uses = |text: &str| -> Vec<usize> {
        super::expression::Expression::parse(text, &name_refs)
            .map(|e| e.names_used())
            .unwrap_or_default()
    };
    let mut dropped = vec![false; names.len()];
    loop {
        let mut changed = false;
        for entry in &file.parameters {
            let Some(text) = &entry.value else { continue };
            let used = uses(text);
            let broken = moved.contains(&entry.name.as_str()) || used.iter().any(|&q| dropped[q]);
            for q in used.into_iter().filter(|_| broken) {
                changed |= !dropped[q];
                dropped[q] = true;
            }
        }
        if !changed {
            break;
        }
    }
    for entry in &mut file.parameters {
        let broken = entry.value.as_deref().is_some_and(|text| {
            moved.contains(&entry.name.as_str()) || uses(text).iter().any(|&q| dropped[q])
        });
        if broken {
            entry.value = None;
        }
    }
    let used: Vec<usize> = file
        .parameters
        .iter()
        .filter_map(|e| e.value.as_deref())
        .flat_map(uses)
        .collect();
    let gone: Vec<&String> = (0..names.len())
        .filter(|&q| dropped[q] || !used.contains(&q))
        .map(|q| &names[q])
        .collect();
    let mut lost = Vec::new();
    file.factor_sets.retain(|set| {
        let keep = !set.fit.iter().any(|f| gone.contains(&f));
        if !keep {
            lost.push(set.name.clone());
        }
        keep
    });
    file.quantities.retain(|q| !gone.contains(&&q.name));
    lost
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::drop_broken_relations;
    use crate::model::file::ModelFile;

    /// `P1 = a` moved: `a` goes, so does `P2 = a + b`'s relation and with it `b`; `P3 = c`
    /// stays, as does the set fitting `c` alone; `d`, used by nothing, goes.
    #[test]
    fn a_moved_parameter_takes_its_quantities_and_their_users_along() {
        let text =
            "name: t\nurdf: t.urdf\nmeasured: [x, y]\nhome: {pose: {x: 0, y: 0}}\nlegs: []\n\
            quantities:\n  - {name: a, value: 1, unit: m}\n  - {name: b, value: 2, unit: m}\n  \
            - {name: c, value: 3, unit: m}\n  - {name: d, value: 4, unit: m}\n\
            parameters:\n  - {name: P1, leg: l, actuator: gain, value: a}\n  \
            - {name: P2, leg: l, actuator: offset, value: a + b}\n  \
            - {name: P3, leg: l, attachment: x, value: c * 2}\n  \
            - {name: P4, leg: l, attachment: y}\n\
            factor_sets:\n  - {name: sa, fit: [a]}\n  - {name: sb, fit: [b, P4]}\n  \
            - {name: sc, fit: [c, P4]}\n  - {name: sd, fit: [d]}\n\
            workspace: {region: {disc: {centre: [0, 0], radius: 1}}}\n";
        let mut file = ModelFile::parse(text, Path::new("t.yaml")).unwrap();
        let lost = drop_broken_relations(&mut file, &["P1"]);
        assert_eq!(lost, ["sa", "sb", "sd"]);
        let values: Vec<Option<&str>> =
            file.parameters.iter().map(|p| p.value.as_deref()).collect();
        assert_eq!(values, [None, None, Some("c * 2"), None]);
        let names: Vec<&str> = file.quantities.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["c"]);
        let sets: Vec<&str> = file.factor_sets.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(sets, ["sc"]);
        // Nothing moved: only the unused `d` (and its set) go.
        let mut file = ModelFile::parse(text, Path::new("t.yaml")).unwrap();
        assert_eq!(drop_broken_relations(&mut file, &[]), ["sd"]);
        assert_eq!(file.quantities.len(), 3);
    }
}
