"""Interactive and command-line image deformation on top of `core` (Sec. 4.3 of the paper).

`app` owns every GL object, window, widget and file: `app.render.renderer` draws meshes with
moderngl, `app.io.files` reads and writes cages, sessions and images, `app.commands.cli` is the
command line (``python -m app``), `app.fit.subject` fits a cage to an image's silhouette and
`app.studies.compare` compares the kernels of `core` on height data, and `app.viewer` is the
interactive viewer (``python -m app``, ``view``, ``demo``).
"""

import os

from app.io.image_header import MAX_IMAGE_PIXELS

# OpenCV reads its pixel limit once, when cv2 is loaded, which every module of app does
# after this: formats whose header app.io.image_header does not read are then limited too.
os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_IMAGE_PIXELS))
# OpenBLAS reads its idle threads' busy wait once, when numpy loads it, which app.commands.cli does
# before it imports core: the value of core.library_threads.IDLE_SPIN (see there).
os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", "20")
