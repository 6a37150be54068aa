//! Scenes bundled into the binary (the files in the repository's `scenes/` folder).

/// (name, TOML text) of every bundled scene, in listing order.
pub const BUNDLED: &[(&str, &str)] = &[
    ("furuta-dt25", include_str!("../../../../scenes/furuta-dt25.toml")),
    ("furuta-dt30.5", include_str!("../../../../scenes/furuta-dt30.5.toml")),
    ("furuta-dt30.8", include_str!("../../../../scenes/furuta-dt30.8.toml")),
    ("furuta-dt31", include_str!("../../../../scenes/furuta-dt31.toml")),
    ("furuta-dt31.2", include_str!("../../../../scenes/furuta-dt31.2.toml")),
    ("furuta-dt31.4", include_str!("../../../../scenes/furuta-dt31.4.toml")),
    ("furuta-dt31.41", include_str!("../../../../scenes/furuta-dt31.41.toml")),
    ("furuta-dt31.55", include_str!("../../../../scenes/furuta-dt31.55.toml")),
    ("furuta-dt31.6", include_str!("../../../../scenes/furuta-dt31.6.toml")),
    ("furuta-dt31.68", include_str!("../../../../scenes/furuta-dt31.68.toml")),
    ("furuta-dt31.8", include_str!("../../../../scenes/furuta-dt31.8.toml")),
    ("furuta-dt32", include_str!("../../../../scenes/furuta-dt32.toml")),
    ("furuta-dt32.2", include_str!("../../../../scenes/furuta-dt32.2.toml")),
    ("furuta-dt32.3", include_str!("../../../../scenes/furuta-dt32.3.toml")),
    ("furuta-dt32.5", include_str!("../../../../scenes/furuta-dt32.5.toml")),
    ("furuta-literal-dt25", include_str!("../../../../scenes/furuta-literal-dt25.toml")),
    ("furuta-microchaos", include_str!("../../../../scenes/furuta-microchaos.toml")),
    ("furuta-noise-pid", include_str!("../../../../scenes/furuta-noise-pid.toml")),
    ("furuta-quant-dt25", include_str!("../../../../scenes/furuta-quant-dt25.toml")),
    ("furuta-quant-dt25-noise", include_str!("../../../../scenes/furuta-quant-dt25-noise.toml")),
    ("furuta-saturation", include_str!("../../../../scenes/furuta-saturation.toml")),
    ("furuta-equations", include_str!("../../../../scenes/furuta-equations.toml")),
    ("cartpole-pd", include_str!("../../../../scenes/cartpole-pd.toml")),
    ("pendulum-pd", include_str!("../../../../scenes/pendulum-pd.toml")),
    ("duffing-chain", include_str!("../../../../scenes/duffing-chain.toml")),
    ("double-pendulum-cart", include_str!("../../../../scenes/double-pendulum-cart.toml")),
    ("duffing-chain4", include_str!("../../../../scenes/duffing-chain4.toml")),
];

/// The TOML text of a bundled scene.
pub fn get(name: &str) -> Option<&'static str> {
    BUNDLED.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// Names of all bundled scenes.
pub fn bundled_names() -> impl Iterator<Item = &'static str> {
    BUNDLED.iter().map(|(n, _)| *n)
}
