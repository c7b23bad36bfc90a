// foldprint viewer bundle: the parts of three.js the fold viewer uses, as one classic script
// (window.FOLDPRINT_THREE) so the pages work from file:// (module scripts do not).
export {
  WebGLRenderer, Scene, OrthographicCamera, PerspectiveCamera, AmbientLight, DirectionalLight, HemisphereLight,
  BufferGeometry, BufferAttribute, Float32BufferAttribute, Mesh, MeshStandardMaterial, MeshLambertMaterial,
  MeshBasicMaterial, LineSegments, LineBasicMaterial, EdgesGeometry, Group, Matrix4, Vector3, Box3, Color,
  SphereGeometry, DoubleSide, GridHelper, Sphere
} from "three";
export { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
