// The wind field W(p, t) of the simulation uniforms (u_sim), and the user's WGSL
// wind. Included by simulate.wgsl and inspect.wgsl (both declare u_sim; the
// template variable user_wind_body is params.wind_wgsl, or a zero wind).

// Wind field by WindField id; "custom" is user_wind.
fn wind_field(p: vec3<f32>, t: f32) -> vec3<f32> {
    switch u_sim.wind_field {
        case {{ wind_field_radial }}: {
            return wind_radial(p, t, u_sim.wind_strength, u_sim.wind_center.xyz, u_sim.wind_radius, u_sim.wind_speed, u_sim.wind_wavelength);
        }
        case {{ wind_field_vortex }}: {
            return wind_vortex(p, t, u_sim.wind_strength, u_sim.wind_center.xyz, u_sim.wind_radius, u_sim.wind_speed, u_sim.wind_wavelength);
        }
        case {{ wind_field_noise }}: {
            return wind_noise(p, t, u_sim.wind_strength, u_sim.wind_dir.xy, u_sim.wind_direction_rad, u_sim.wind_speed, u_sim.wind_wavelength);
        }
        case {{ wind_field_custom }}: {
            return user_wind(p, t);
        }
        default: {  // {{ wind_field_wave }}
            return wind_wave(p, t, u_sim.wind_strength, u_sim.wind_dir.xy, u_sim.wind_speed, u_sim.wind_wavelength);
        }
    }
}

// The user's wind (wind_field "custom"): params.wind_wgsl is the body, inserted
// verbatim on the line after this signature (GrassField maps compile errors back
// to lines of the snippet from there). Empty snippet: no wind.
fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32> {
{{ user_wind_body }}
}
