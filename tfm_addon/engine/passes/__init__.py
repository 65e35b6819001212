"""The GPU passes, a module each: solids' geometry, shadow map, G-buffer, TFM, scattering."""
