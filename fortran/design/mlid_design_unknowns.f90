!> A design's unknowns by name: elements of F, G or H of a linear model
!> (mlid_layout's element names), turned into what mlid_design's
!> design_create takes (a block code, row and column each).  The deck's
!> &design and Python's InputDesign both ask here.
module mlid_design_unknowns
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_layout, only: layout_table_t, element_index, element_name, locate
  implicit none
  private
  public :: unknown_entries, unknown_blocks, DESIGN_BLOCKS

  !> The blocks an unknown may be in; its block code is the place here
  !> (design_create: 1 F, 2 G, 3 H).
  character(len=8), parameter :: DESIGN_BLOCKS(3) = [character(len=8) :: 'f', 'g', 'h']

contains

  !> The entries of theta of the design unknowns named (element names of a
  !> linear model's layout lt; blank entries are none).  A name that is no
  !> element within the dimensions, or one listed twice, is refused: msg
  !> names it ("unknown 'f(3,1)' ...").
  subroutine unknown_entries(lt, names, idx, status, msg)
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: names(:)
    integer, allocatable, intent(out) :: idx(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, i
    allocate (idx(0))
    status = MLID_ERR_INPUT
    do k = 1, size(names)
      if (len_trim(names(k)) == 0) cycle
      i = element_index(lt, names(k))
      if (i == 0) then
        msg = 'unknown '''//trim(adjustl(names(k)))//''' is no element of F, G or H within '// &
              'the dimensions'
        return
      end if
      if (any(idx == i)) then
        msg = 'unknown '''//trim(adjustl(names(k)))//''' listed twice'
        return
      end if
      idx = [idx, i]
    end do
    status = MLID_OK
    msg = ''
  end subroutine unknown_entries

  !> What design_create takes of the unknowns at entries idx of theta: the
  !> block (1 F, 2 G, 3 H), row and column of each.  An entry outside F, G
  !> and H is refused, named.
  subroutine unknown_blocks(lt, idx, ukind, urow, ucol, status, msg)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: idx(:)
    integer, allocatable, intent(out) :: ukind(:), urow(:), ucol(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, b
    allocate (ukind(size(idx)), urow(size(idx)), ucol(size(idx)))
    status = MLID_OK
    msg = ''
    do k = 1, size(idx)
      call locate(lt, idx(k), b, urow(k), ucol(k))
      ukind(k) = findloc(DESIGN_BLOCKS, lt%key(b), 1)
      if (ukind(k) == 0) then
        status = MLID_ERR_INPUT
        msg = 'unknown '''//trim(element_name(lt, idx(k)))//''' is no element of F, G or H '// &
              '(the design''s unknowns are)'
        return
      end if
    end do
  end subroutine unknown_blocks

end module mlid_design_unknowns
