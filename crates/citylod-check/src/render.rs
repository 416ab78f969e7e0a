//! Headless wgpu renderer (Vulkan; Mesa lavapipe without a GPU): draws a [`Scene`] from a [`Camera`]
//! into an offscreen RGBA8 colour target, an R32Uint feature-id target and a Depth32Float depth buffer.
//! Vertices are moved to the eye, projected and flat-shaded on the CPU in f64 (no f32 precision loss
//! far from the origin); the GPU rasterizes with reverse-Z (infinite far plane) and no face culling.
//! Invariant: the same scene, camera and size give byte-identical images.

use std::sync::mpsc;

use bytemuck::{Pod, Zeroable};

use crate::camera::{Camera, NEAR_M};
use crate::vec3::{self, Vec3};
use crate::{CheckError, Image, Scene};

/// Background colour of every render.
pub const SKY: [u8; 4] = [190, 214, 238, 255];
/// Feature id of a pixel no triangle covers.
pub const NO_FEATURE: u32 = u32::MAX;
/// Unit vector towards the sun (from the south-west, 50° up), root frame.
const LIGHT: Vec3 = [-0.37, -0.52, 0.77];
/// Share of a surface's colour it keeps in shadow.
const AMBIENT: f64 = 0.45;
/// Triangles per draw call and vertex buffer (3 · 2²⁰ vertices · 24 B = 72 MiB, under wgpu's
/// default 256 MiB buffer limit).
const CHUNK_TRIANGLES: usize = 1 << 20;

const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const FEATURE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Everything one render produces, all `width × height`, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderLayers {
    pub colour: Image,
    /// Feature id per pixel, [`NO_FEATURE`] for background.
    pub feature_ids: Vec<u32>,
    /// Distance along the view axis (m) per pixel, `f32::INFINITY` for background.
    pub depth_m: Vec<f32>,
}

/// A GPU device and the one pipeline the checker draws with. Reuse it across renders.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::RenderPipeline,
    adapter_name: String,
    max_size_px: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Vertex {
    clip: [f32; 4],
    colour: [u8; 4],
    feature: u32,
}

impl Renderer {
    /// Opens a Vulkan adapter (a real GPU first, then a software fallback such as lavapipe) and builds
    /// the pipeline. Errors with an install hint when there is no adapter.
    pub fn new() -> Result<Renderer, CheckError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            flags: wgpu::InstanceFlags::empty(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let request = |force_fallback_adapter: bool| {
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter,
                compatible_surface: None,
                ..Default::default()
            }))
        };
        let adapter = match request(false) {
            Ok(a) => a,
            Err(first) => request(true).map_err(|second| {
                let (first, second) = (first.to_string(), second.to_string());
                CheckError::NoAdapter {
                    detail: if first == second {
                        first
                    } else {
                        format!("{first}; with a fallback adapter: {second}")
                    },
                }
            })?,
        };
        let info = adapter.get_info();
        let adapter_name = format!("{} ({:?}, {})", info.name, info.device_type, info.driver);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("citylod-check"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::default(),
            ..Default::default()
        }))
        .map_err(|e| CheckError::Device {
            adapter: adapter_name.clone(),
            detail: e.to_string(),
        })?;
        let max_size_px = device.limits().max_texture_dimension_2d;

        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipeline = build_pipeline(&device);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(CheckError::Render {
                stage: "pipeline creation",
                detail: e.to_string(),
            });
        }
        Ok(Renderer {
            device,
            queue,
            pipeline,
            adapter_name,
            max_size_px,
        })
    }

    /// The largest width or height a render may have on this device (its largest 2D texture; 8192 on lavapipe).
    pub fn max_size_px(&self) -> u32 {
        self.max_size_px
    }

    /// Name, type and driver of the adapter in use, e.g. `llvmpipe (LLVM 19.1.7, 256 bits) (Cpu, llvmpipe)`.
    pub fn adapter_name(&self) -> &str {
        &self.adapter_name
    }

    /// Renders the colour image of `scene` seen by `camera` at `width_px × height_px`.
    pub fn render(
        &self,
        scene: &Scene,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> Result<Image, CheckError> {
        Ok(self
            .render_layers(scene, camera, width_px, height_px)?
            .colour)
    }

    /// Renders colour, feature ids and depth. Errors when a size is 0 or above the device limit, or
    /// when the GPU reports an error.
    pub fn render_layers(
        &self,
        scene: &Scene,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> Result<RenderLayers, CheckError> {
        let mut canvas = self.canvas(camera, width_px, height_px)?;
        canvas.draw(scene)?;
        canvas.finish()
    }

    /// An empty `width_px × height_px` target seen by `camera`, to draw scenes into one after another
    /// ([`Canvas::draw`]) and read back once ([`Canvas::finish`]): a scene too large to hold at once is drawn in
    /// batches, each freed before the next, with the same pixels as when drawn whole. Errors when a size is 0 or
    /// above the device limit.
    pub fn canvas(
        &self,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> Result<Canvas<'_>, CheckError> {
        if width_px == 0 || height_px == 0 || width_px.max(height_px) > self.max_size_px {
            return Err(CheckError::Image(format!(
                "render size {width_px}×{height_px} must be between 1 and {} px",
                self.max_size_px
            )));
        }
        let size = wgpu::Extent3d {
            width: width_px,
            height: height_px,
            depth_or_array_layers: 1,
        };
        let target = |label, format| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        Ok(Canvas {
            renderer: self,
            camera: *camera,
            size,
            colour: target("colour", COLOUR_FORMAT),
            feature: target("feature", FEATURE_FORMAT),
            depth: target("depth", DEPTH_FORMAT),
            cleared: false,
        })
    }

    /// Runs `record` on a command encoder, submits it and waits for the GPU; a validation or out-of-memory
    /// error raised meanwhile is returned as a render error of `stage`.
    fn submit_and_wait(
        &self,
        stage: &'static str,
        record: impl FnOnce(&mut wgpu::CommandEncoder),
    ) -> Result<(), CheckError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("citylod-check render"),
            });
        record(&mut encoder);
        let submission = self.queue.submit([encoder.finish()]);
        let waited = self.device.poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        });
        let errors = [
            pollster::block_on(validation.pop()),
            pollster::block_on(oom.pop()),
        ];
        if let Some(e) = errors.into_iter().flatten().next() {
            return Err(CheckError::Render {
                stage,
                detail: e.to_string(),
            });
        }
        waited.map(|_| ()).map_err(|e| CheckError::Render {
            stage: "waiting for the GPU",
            detail: e.to_string(),
        })
    }

    /// Unpads the three mapped layers into a [`RenderLayers`].
    fn read_back(
        &self,
        readback: wgpu::Buffer,
        width: u32,
        height: u32,
    ) -> Result<RenderLayers, CheckError> {
        let row_bytes = padded_row_bytes(width) as usize;
        let (w, h) = (width as usize, height as usize);
        let layer_bytes = row_bytes * h;
        let mapped = readback
            .get_mapped_range(..)
            .map_err(|e| CheckError::Render {
                stage: "reading the readback buffer",
                detail: e.to_string(),
            })?;
        let bytes: &[u8] = &mapped;
        let rows = |layer: usize| {
            let base = layer * layer_bytes;
            (0..h).flat_map(move |y| {
                let start = base + y * row_bytes;
                bytes[start..start + w * 4]
                    .chunks_exact(4)
                    .map(|c| [c[0], c[1], c[2], c[3]])
            })
        };
        let rgba: Vec<u8> = rows(0).flatten().collect();
        let feature_ids = rows(1)
            .map(|b| u32::from_le_bytes(b).wrapping_sub(1)) // 0 (cleared) → NO_FEATURE
            .collect();
        let depth_m = rows(2)
            .map(|b| {
                let ndc = f32::from_le_bytes(b);
                if ndc > 0.0 {
                    NEAR_M as f32 / ndc
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        drop(mapped);
        readback.unmap();
        Ok(RenderLayers {
            colour: Image::from_rgba(width, height, rgba)?,
            feature_ids,
            depth_m,
        })
    }
}

/// A render target being drawn: see [`Renderer::canvas`].
pub struct Canvas<'r> {
    renderer: &'r Renderer,
    camera: Camera,
    size: wgpu::Extent3d,
    colour: wgpu::Texture,
    feature: wgpu::Texture,
    depth: wgpu::Texture,
    /// Whether a pass has cleared the targets yet (the first one does).
    cleared: bool,
}

impl Canvas<'_> {
    /// Draws `scene` over what is already drawn (depth-tested, as if its triangles followed the earlier
    /// scenes' in one scene), then frees its buffers. Errors when the GPU reports an error.
    pub fn draw(&mut self, scene: &Scene) -> Result<(), CheckError> {
        let aspect = f64::from(self.size.width) / f64::from(self.size.height);
        let vertices = clip_space_vertices(scene, &self.camera, aspect);
        if vertices.is_empty() && self.cleared {
            return Ok(());
        }
        let r = self.renderer;
        let chunks: Vec<wgpu::Buffer> = vertices
            .chunks(3 * CHUNK_TRIANGLES)
            .map(|chunk| {
                let buffer = r.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("vertices"),
                    size: std::mem::size_of_val(chunk) as u64,
                    usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                r.queue
                    .write_buffer(&buffer, 0, bytemuck::cast_slice(chunk));
                buffer
            })
            .collect();
        drop(vertices);
        let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        let (colour_view, feature_view, depth_view) =
            (view(&self.colour), view(&self.feature), view(&self.depth));
        let first = !self.cleared;
        let load = |clear: wgpu::Color| {
            if first {
                wgpu::LoadOp::Clear(clear)
            } else {
                wgpu::LoadOp::Load
            }
        };
        let [red, green, blue, alpha] = SKY.map(|c| f64::from(c) / 255.0);
        r.submit_and_wait("drawing", |encoder| {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[
                    Some(wgpu::RenderPassColorAttachment {
                        view: &colour_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: load(wgpu::Color {
                                r: red,
                                g: green,
                                b: blue,
                                a: alpha,
                            }),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                    Some(wgpu::RenderPassColorAttachment {
                        view: &feature_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: load(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: if first {
                            wgpu::LoadOp::Clear(0.0)
                        } else {
                            wgpu::LoadOp::Load
                        },
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&r.pipeline);
            for buffer in &chunks {
                let n = (buffer.size() / std::mem::size_of::<Vertex>() as u64) as u32;
                pass.set_vertex_buffer(0, buffer.slice(..));
                pass.draw(0..n, 0..1);
            }
        })?;
        self.cleared = true;
        Ok(())
    }

    /// Reads the three layers back (the sky alone when nothing was drawn).
    pub fn finish(mut self) -> Result<RenderLayers, CheckError> {
        if !self.cleared {
            self.draw(&Scene::new())?;
        }
        let r = self.renderer;
        let (width, height) = (self.size.width, self.size.height);
        let row_bytes = padded_row_bytes(width);
        let layer_bytes = u64::from(row_bytes) * u64::from(height);
        let readback = r.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: 3 * layer_bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        r.submit_and_wait("copying the render out", |encoder| {
            for (i, (texture, aspect)) in [
                (&self.colour, wgpu::TextureAspect::All),
                (&self.feature, wgpu::TextureAspect::All),
                (&self.depth, wgpu::TextureAspect::DepthOnly),
            ]
            .into_iter()
            .enumerate()
            {
                encoder.copy_texture_to_buffer(
                    wgpu::TexelCopyTextureInfo {
                        texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d::ZERO,
                        aspect,
                    },
                    wgpu::TexelCopyBufferInfo {
                        buffer: &readback,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: i as u64 * layer_bytes,
                            bytes_per_row: Some(row_bytes),
                            rows_per_image: Some(height),
                        },
                    },
                    self.size,
                );
            }
        })?;
        let (tx, rx) = mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |m| {
            let _ = tx.send(m);
        });
        r.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map_err(|e| CheckError::Render {
                stage: "waiting for the GPU",
                detail: e.to_string(),
            })?;
        match rx.recv() {
            Ok(Ok(())) => r.read_back(readback, width, height),
            Ok(Err(e)) => Err(CheckError::Render {
                stage: "mapping the readback buffer",
                detail: e.to_string(),
            }),
            Err(_) => Err(CheckError::Render {
                stage: "mapping the readback buffer",
                detail: "the map callback never ran".into(),
            }),
        }
    }
}

fn build_pipeline(device: &wgpu::Device) -> wgpu::RenderPipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("citylod-check render.wgsl"),
        source: wgpu::ShaderSource::Wgsl(include_str!("render.wgsl").into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("citylod-check"),
        bind_group_layouts: &[],
        immediate_size: 0,
    });
    let attributes = [
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: 0,
            shader_location: 0,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Unorm8x4,
            offset: 16,
            shader_location: 1,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Uint32,
            offset: 20,
            shader_location: 2,
        },
    ];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("citylod-check flat"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[
                Some(wgpu::ColorTargetState {
                    format: COLOUR_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                }),
                Some(wgpu::ColorTargetState {
                    format: FEATURE_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                }),
            ],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Bytes per row of a 4-byte-per-texel copy, rounded up to wgpu's copy alignment (256).
fn padded_row_bytes(width: u32) -> u32 {
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    (width * 4).div_ceil(align) * align
}

/// Moves, projects and shades every triangle on the CPU. Output: three clip-space vertices per
/// drawn triangle; triangles that are degenerate or entirely outside one frustum plane are dropped.
fn clip_space_vertices(scene: &Scene, camera: &Camera, aspect: f64) -> Vec<Vertex> {
    let sy = 1.0 / camera.tan_half_fovy();
    let sx = sy / aspect;
    let light = vec3::normalize(LIGHT);
    let mut out = Vec::with_capacity(scene.triangles.len() * 3);
    for ((tri, colour), &feature) in scene
        .triangles
        .iter()
        .zip(&scene.colours)
        .zip(&scene.feature_ids)
    {
        let p = tri.map(|i| scene.positions_m[i as usize]);
        let n = vec3::normalize(vec3::cross(vec3::sub(p[1], p[0]), vec3::sub(p[2], p[0])));
        if n == [0.0; 3] {
            continue;
        }
        let v = p.map(|q| camera.to_view(q));
        // clip = (x·sx, y·sy, near, z): NDC depth near/z is 1 at the near plane and → 0 far away.
        let clip = v.map(|[x, y, z]| [x * sx, y * sy, NEAR_M, z]);
        let outside = |f: &dyn Fn(&[f64; 4]) -> bool| clip.iter().all(f);
        if outside(&|c| c[3] < NEAR_M)
            || outside(&|c| c[0] > c[3])
            || outside(&|c| c[0] < -c[3])
            || outside(&|c| c[1] > c[3])
            || outside(&|c| c[1] < -c[3])
        {
            continue;
        }
        // Light the side facing the eye: meshes of other tools may be wound either way.
        let towards_eye = vec3::sub(camera.eye_m, p[0]);
        let n = if vec3::dot(n, towards_eye) < 0.0 {
            vec3::scale(n, -1.0)
        } else {
            n
        };
        let shade = AMBIENT + (1.0 - AMBIENT) * vec3::dot(n, light).max(0.0);
        let mut rgb = [0, 1, 2].map(|c| (f64::from(colour[c]) * shade).round().min(255.0) as u8);
        if [rgb[0], rgb[1], rgb[2], 255] == SKY {
            rgb[2] -= 1; // a building must never read as background
        }
        for c in clip {
            out.push(Vertex {
                clip: c.map(|x| x as f32),
                colour: [rgb[0], rgb[1], rgb[2], 255],
                feature: feature.wrapping_add(1),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::box_mesh;
    use citylod_model::Mesh3d;

    fn renderer() -> Renderer {
        Renderer::new().unwrap_or_else(|e| {
            panic!(
                "rendering tests need a Vulkan adapter (Mesa lavapipe on machines without a GPU; \
                 `make setup` installs mesa-vulkan-drivers libvulkan1): {e}"
            )
        })
    }

    fn cube_scene() -> Scene {
        let mut s = Scene::new();
        s.add_mesh(
            &box_mesh([-0.5, 9.5, -0.5], [0.5, 10.5, 0.5]),
            [200, 80, 60, 255],
            42,
        )
        .unwrap();
        s
    }

    #[test]
    fn unit_cube_ahead_covers_centre_but_not_corners() {
        let r = renderer();
        // Looking north at a unit cube 10 m ahead through a 30° fov: it spans ~7 % of the height.
        let cam = Camera::from_enu([0.0; 3], 0.0, 0.0, 30.0).unwrap();
        let layers = r.render_layers(&cube_scene(), &cam, 64, 48).unwrap();
        let img = &layers.colour;
        assert_ne!(
            img.pixel(32, 24).unwrap(),
            SKY,
            "centre pixel should show the cube"
        );
        for (x, y) in [(0, 0), (63, 0), (0, 47), (63, 47)] {
            assert_eq!(img.pixel(x, y).unwrap(), SKY, "corner ({x}, {y})");
        }
        assert_eq!(layers.feature_ids[24 * 64 + 32], 42);
        assert_eq!(layers.feature_ids[0], NO_FEATURE);
        let d = layers.depth_m[24 * 64 + 32];
        assert!((d - 9.5).abs() < 1e-3, "depth {d}");
        assert!(layers.depth_m[0].is_infinite());
    }

    #[test]
    fn two_renders_are_byte_identical() {
        let r = renderer();
        let scene = city_scene();
        let cam = Camera::from_enu([0.0, -20.0, 40.0], 10.0, -25.0, 50.0).unwrap();
        let a = r.render_layers(&scene, &cam, 320, 200).unwrap();
        let b = r.render_layers(&scene, &cam, 320, 200).unwrap();
        assert!(
            a.colour.rgba != vec![SKY; 320 * 200].concat(),
            "something must be drawn"
        );
        assert_eq!(a, b);
        let c = renderer().render_layers(&scene, &cam, 320, 200).unwrap();
        assert_eq!(a, c, "a fresh device must give the same bytes");
    }

    /// 40 boxes of varying height in rows (they hide one another when seen obliquely), with their ids.
    fn city_boxes() -> Vec<(Mesh3d, u32)> {
        (0..40)
            .map(|i| {
                let x = f64::from(i % 8) * 12.0 - 48.0;
                let y = f64::from(i / 8) * 15.0 + 30.0;
                let h = 5.0 + f64::from((i * 7) % 11) * 3.0;
                (box_mesh([x, y, 0.0], [x + 9.0, y + 11.0, h]), i)
            })
            .collect()
    }

    /// The cube and the city's boxes.
    fn city_scene() -> Scene {
        let mut scene = cube_scene();
        for (mesh, id) in city_boxes() {
            scene.add_mesh(&mesh, [180, 170, 150, 255], id).unwrap();
        }
        scene
    }

    #[test]
    fn a_scene_drawn_in_batches_gives_the_same_layers_as_drawn_whole() {
        let r = renderer();
        let whole = city_scene();
        let cam = Camera::from_enu([0.0, -20.0, 40.0], 10.0, -25.0, 50.0).unwrap();
        let expected = r.render_layers(&whole, &cam, 320, 200).unwrap();
        // The same triangles, in the same order, split unevenly over three scenes (one empty).
        let (mut a, mut b) = (cube_scene(), Scene::new());
        for (k, (mesh, id)) in city_boxes().into_iter().enumerate() {
            let target = if k < 13 { &mut a } else { &mut b };
            target.add_mesh(&mesh, [180, 170, 150, 255], id).unwrap();
        }
        assert_eq!(
            a.triangle_count() + b.triangle_count(),
            whole.triangle_count()
        );
        let mut canvas = r.canvas(&cam, 320, 200).unwrap();
        for s in [&a, &Scene::new(), &b] {
            canvas.draw(s).unwrap();
        }
        let batched = canvas.finish().unwrap();
        assert_eq!(batched, expected);
        // Drawing only the first batch leaves the second's boxes out: the comparison can fail.
        let mut canvas = r.canvas(&cam, 320, 200).unwrap();
        canvas.draw(&a).unwrap();
        assert_ne!(canvas.finish().unwrap(), expected);
        // Nothing drawn: the sky.
        let empty = r.canvas(&cam, 4, 3).unwrap().finish().unwrap();
        assert_eq!(empty.colour.rgba, SKY.repeat(12));
        assert_eq!(empty.feature_ids, vec![NO_FEATURE; 12]);
    }

    #[test]
    fn odd_width_is_unpadded_correctly() {
        // 37 px × 4 B = 148 B per row, padded to 256 on the GPU side.
        let r = renderer();
        let cam = Camera::from_enu([0.0; 3], 0.0, 0.0, 30.0).unwrap();
        let img = r.render(&cube_scene(), &cam, 37, 21).unwrap();
        assert_eq!(img.rgba.len(), 37 * 21 * 4);
        assert_ne!(img.pixel(18, 10).unwrap(), SKY);
        assert_eq!(img.pixel(36, 20).unwrap(), SKY);
    }

    #[test]
    fn geometry_far_from_the_origin_keeps_its_shape() {
        // The same cube 20 km from the root origin renders like the one at the origin: the eye-relative
        // transform runs in f64.
        let r = renderer();
        let off = [20_000.0, -15_000.0, 0.0];
        let mut far = Scene::new();
        far.add_mesh(
            &box_mesh(
                vec3::add(off, [-0.5, 9.5, -0.5]),
                vec3::add(off, [0.5, 10.5, 0.5]),
            ),
            [200, 80, 60, 255],
            42,
        )
        .unwrap();
        let near_cam = Camera::from_enu([0.0; 3], 0.0, 0.0, 30.0).unwrap();
        let far_cam = Camera::from_enu(off, 0.0, 0.0, 30.0).unwrap();
        assert_eq!(
            r.render(&cube_scene(), &near_cam, 64, 48).unwrap(),
            r.render(&far, &far_cam, 64, 48).unwrap()
        );
    }

    #[test]
    fn far_standard_view_shows_every_building() {
        let r = renderer();
        let mut scene = Scene::new();
        for i in 0..36u32 {
            let (x, y) = (f64::from(i % 6) * 60.0, f64::from(i / 6) * 45.0);
            let h = 8.0 + f64::from(i % 5) * 6.0;
            scene
                .add_mesh(
                    &box_mesh([x, y, 0.0], [x + 25.0, y + 20.0, h]),
                    [170, 160, 150, 255],
                    i,
                )
                .unwrap();
        }
        let (lo, hi) = scene.bounds().unwrap();
        let far = crate::standard_views(lo, hi, 5)[0];
        let layers = r.render_layers(&scene, &far, 400, 300).unwrap();
        let mut seen: Vec<u32> = layers.feature_ids.clone();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen, (0..36).chain([NO_FEATURE]).collect::<Vec<_>>());
    }

    #[test]
    fn zero_size_is_an_error() {
        let r = renderer();
        let cam = Camera::from_enu([0.0; 3], 0.0, 0.0, 30.0).unwrap();
        assert!(r.render(&cube_scene(), &cam, 0, 10).is_err());
    }
}
