!> The Python extension's GIL, for the flat interface to hand the job
!> runner as its hooks around a fit (mlid_run's around_t): defined in C by
!> the extension (python/mlid/_gil.c), so only what links the extension
!> may use this module; f2py does not wrap it, and mlid-batch never uses
!> the flat interface.
module mlid_gil
  implicit none
  private
  public :: gil_release, gil_restore

  interface
    !> Release the GIL the calling thread holds (nothing when it holds none).
    subroutine gil_release() bind(c, name='mlid_gil_release')
    end subroutine gil_release
    !> Take it back.
    subroutine gil_restore() bind(c, name='mlid_gil_restore')
    end subroutine gil_restore
  end interface
end module mlid_gil
